r"""Coarse alignment: levelling from the mean specific force, heading from the GNSS track.

In ENU navigation / FLU body axes, at rest (or at constant velocity) the accelerometer
reads :math:`f^b = C_{nb}^\top [0, 0, g]`; with the Z-Y-X Euler angles of
:func:`nav.euler.euler_zyx_to_q` (:math:`C_{nb} = R_z(\psi)R_y(\theta)R_x(\phi)`):

.. math::

    f^b = g\,[-\sin\theta,\ \sin\phi\cos\theta,\ \cos\phi\cos\theta]
    \;\Rightarrow\;
    \phi = \mathrm{atan2}(f_y, f_z),\quad
    \theta = \mathrm{atan2}(-f_x, \sqrt{f_y^2 + f_z^2}).

A vehicle whose forward axis points along its velocity (no side slip) has the heading of
its GNSS track, :math:`\psi = \mathrm{atan2}(\Delta n, \Delta e)` (from east,
counter-clockwise).  A horizontal acceleration :math:`a` during the levelling window tilts
the estimate by about :math:`a/g` rad; the caller's prior σ must cover it.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nav.euler import euler_zyx_to_q

Array = NDArray[np.float64]

__all__ = ["coarse_alignment", "level", "track_heading"]


def level(mean_specific_force: ArrayLike) -> tuple[float, float]:
    """``(roll, pitch)`` (rad) from the mean FLU specific force (module docstring)."""
    f = np.asarray(mean_specific_force, dtype=np.float64)
    return (math.atan2(f[1], f[2]), math.atan2(-f[0], math.hypot(f[1], f[2])))


def track_heading(p_from: ArrayLike, p_to: ArrayLike) -> float:
    """Heading (rad, ENU: from east, counter-clockwise) of the horizontal displacement."""
    d = np.asarray(p_to, dtype=np.float64) - np.asarray(p_from, dtype=np.float64)
    if math.hypot(d[0], d[1]) == 0.0:
        raise ValueError("no horizontal displacement: the heading is undefined")
    return math.atan2(d[1], d[0])


def coarse_alignment(mean_specific_force: ArrayLike, p_from: ArrayLike, p_to: ArrayLike
                     ) -> Array:
    """``q_nb`` (4,) from levelling and the GNSS track heading."""
    roll, pitch = level(mean_specific_force)
    return euler_zyx_to_q(roll, pitch, track_heading(p_from, p_to))
