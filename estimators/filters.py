"""The filters by name, as the command line, the code and ``summary.json`` name them.

=========  ===========================================================
``ekf``    extended Kalman filter (Joseph form)
``ckf``    cubature Kalman filter, dense covariance
``ukf``    unscented Kalman filter, dense covariance
``cdkf``   central-difference Kalman filter, dense covariance
``srckf``  square-root cubature Kalman filter (QR / ``tria``)
``srukf``  square-root unscented Kalman filter (QR + Cholesky downdate)
``srcdkf`` square-root central-difference Kalman filter
``svdckf`` cubature Kalman filter with an SVD-factored covariance
=========  ===========================================================
"""

from __future__ import annotations

import numpy as np

from .ekf import ExtendedKalmanFilter
from .rules import CentralDifference, Cubature, Unscented
from .sigma import SigmaPointFilter

Filter = ExtendedKalmanFilter | SigmaPointFilter

FILTER_NAMES: tuple[str, ...] = ("ekf", "ckf", "ukf", "cdkf", "srckf", "srukf", "srcdkf",
                                 "svdckf")


def make_filter(name: str, *, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0,
                h: float = float(np.sqrt(3.0))) -> Filter:
    """Build the filter called ``name``.

    ``alpha``, ``beta``, ``kappa`` tune the unscented rule (defaults give positive
    weights for any dimension); ``h`` is the central-difference step.
    """
    ut = Unscented(alpha, beta, kappa)
    cd = CentralDifference(h)
    table: dict[str, Filter] = {
        "ekf": ExtendedKalmanFilter(),
        "ckf": SigmaPointFilter("ckf", Cubature(), "dense"),
        "ukf": SigmaPointFilter("ukf", ut, "dense"),
        "cdkf": SigmaPointFilter("cdkf", cd, "dense"),
        "srckf": SigmaPointFilter("srckf", Cubature(), "sqrt"),
        "srukf": SigmaPointFilter("srukf", ut, "sqrt"),
        "srcdkf": SigmaPointFilter("srcdkf", cd, "sqrt"),
        "svdckf": SigmaPointFilter("svdckf", Cubature(), "svd"),
    }
    if name not in table:
        raise ValueError(f"unknown filter {name!r}; choose from {', '.join(FILTER_NAMES)}")
    return table[name]
