"""The filters by name, as the command line, the code and ``summary.json`` name them.

===========  =========================================================
``ekf``      extended Kalman filter (Joseph form)
``ckf``      cubature Kalman filter, dense covariance
``ukf``      unscented Kalman filter, dense covariance
``cdkf``     central-difference Kalman filter, dense covariance
``srckf``    square-root cubature Kalman filter (QR / ``tria``)
``srukf``    square-root unscented Kalman filter (QR + Cholesky downdate)
``srcdkf``   square-root central-difference Kalman filter
``svdckf``   cubature Kalman filter with an SVD-factored covariance
``hommukf``  high-order moment-matching UKF ([Ding 2017]), dense covariance
===========  =========================================================

Robust filters (:data:`ROBUST_FILTER_NAMES`; they do *not* reduce to the Kalman filter
on a linear model for finite ``gamma``, so they are kept out of :data:`FILTER_NAMES`):

===========  =========================================================
``srchinf``  square-root cubature H∞ Kalman filter ([Spin SR-CH∞KF]), bound ``gamma``
``uthinf``   unscented H∞ filter ([Wu-Wang 2014]), dense covariance, bound ``gamma``
===========  =========================================================
"""

from __future__ import annotations

import numpy as np

from .ekf import ExtendedKalmanFilter
from .hinf import HInfinityFilter, OnFailure
from .homm import HighOrderMoment
from .rules import CentralDifference, Cubature, Unscented
from .sigma import SigmaPointFilter

Filter = ExtendedKalmanFilter | SigmaPointFilter | HInfinityFilter

FILTER_NAMES: tuple[str, ...] = ("ekf", "ckf", "ukf", "cdkf", "srckf", "srukf", "srcdkf",
                                 "svdckf", "hommukf")

ROBUST_FILTER_NAMES: tuple[str, ...] = ("srchinf", "uthinf")


def make_filter(name: str, *, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0,
                h: float = float(np.sqrt(3.0)), gamma: float = 5.0,
                on_failure: OnFailure = "raise") -> Filter:
    """Build the filter called ``name``.

    ``alpha``, ``beta``, ``kappa`` tune the unscented rule (defaults give positive
    weights for any dimension; also used by ``uthinf``); ``h`` is the central-difference
    step.  ``gamma`` is the H∞ bound of ``srchinf``/``uthinf`` (default 5, [Wu-Wang 2014]'s
    value; ``inf`` gives the Kalman twin) and ``on_failure`` what they do when the
    Riccati existence condition fails (``"raise"`` or ``"kalman"``, see
    :mod:`estimators.hinf`).  Other filters ignore both.
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
        "hommukf": SigmaPointFilter("hommukf", HighOrderMoment(), "dense"),
        "srchinf": HInfinityFilter("srchinf", Cubature(), "sqrt", gamma, on_failure),
        "uthinf": HInfinityFilter("uthinf", ut, "dense", gamma, on_failure),
    }
    if name not in table:
        names = ", ".join(FILTER_NAMES + ROBUST_FILTER_NAMES)
        raise ValueError(f"unknown filter {name!r}; choose from {names}")
    return table[name]
