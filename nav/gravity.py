r"""WGS-84 normal gravity by latitude and height.

Somigliana's closed form on the ellipsoid and the second-order free-air correction
(NIMA TR8350.2, eq. 4-1 and 4-3):

.. math::

    \gamma(\varphi) = \gamma_e\,\frac{1 + k\sin^2\varphi}{\sqrt{1 - e^2\sin^2\varphi}},
    \qquad
    \gamma(\varphi, h) = \gamma(\varphi)\Big[1 - \frac{2}{a}\big(1 + f + m
        - 2f\sin^2\varphi\big)h + \frac{3}{a^2}h^2\Big],

with :math:`k = b\gamma_p/(a\gamma_e) - 1` and :math:`m = \omega^2a^2b/GM`.  Gravity points
down the local vertical: :math:`g^n = [0, 0, -\gamma]` in ENU, :math:`[0, 0, \gamma]` in NED.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

#: WGS-84 semi-major axis (m), flattening, Earth rate (rad/s), GM (m^3/s^2).
A = 6378137.0
F = 1.0 / 298.257223563
OMEGA = 7.292115e-5
GM = 3.986004418e14
#: Normal gravity at the equator and at the poles (m/s^2).
GAMMA_E = 9.7803253359
GAMMA_P = 9.8321849378
B = A * (1.0 - F)
E2 = F * (2.0 - F)
#: Somigliana's constant k (published; b γ_p / (a γ_e) - 1 to the constants' rounding).
K = 0.00193185265241
M = OMEGA**2 * A**2 * B / GM

__all__ = ["A", "B", "E2", "F", "GAMMA_E", "GAMMA_P", "normal_gravity", "gravity_vector"]


def normal_gravity(latitude_rad: ArrayLike, height_m: ArrayLike = 0.0) -> Array:
    """Magnitude of WGS-84 normal gravity (m/s²) at geodetic latitude and ellipsoidal height
    (module docstring); broadcasts."""
    s2 = np.sin(np.asarray(latitude_rad, dtype=np.float64)) ** 2
    h = np.asarray(height_m, dtype=np.float64)
    g0 = GAMMA_E * (1.0 + K * s2) / np.sqrt(1.0 - E2 * s2)
    return g0 * (1.0 - 2.0 / A * (1.0 + F + M - 2.0 * F * s2) * h + 3.0 / A**2 * h * h)


def gravity_vector(latitude_rad: float, height_m: float = 0.0, frame: str = "ENU") -> Array:
    """:math:`g^n` in the local-level ``frame`` ("ENU": ``[0, 0, -γ]``; "NED": ``[0, 0, γ]``)."""
    g = float(normal_gravity(latitude_rad, height_m))
    if frame == "ENU":
        return np.array([0.0, 0.0, -g])
    if frame == "NED":
        return np.array([0.0, 0.0, g])
    raise ValueError(f"frame {frame!r}: ENU or NED")


