r"""GNSS position, velocity and position + velocity measurements of an INS state.

The state holds position ``p`` (3), velocity ``v`` (3) and the attitude ``q_nb`` (4) at
ambient columns ``layout.p, layout.v, layout.q`` (tangent: ``δp, δv, δθ`` at
``layout.tp, .tv, .tth``, the body-frame attitude error
:math:`C = \hat C\,\mathrm{Exp}(\delta\theta)`), and the gyro bias at tangent ``layout.tbg``.
With a lever arm :math:`\ell` (body frame, IMU to antenna) and the bias-corrected body rate
:math:`\omega`:

.. math::

    z_p = p + C\ell + v_p, \qquad z_v = v + C(\omega\times\ell) + v_v,

    \frac{\partial z_p}{\partial\delta\theta} = -\hat C[\ell\times], \quad
    \frac{\partial z_v}{\partial\delta\theta} = -\hat C[(\omega\times\ell)\times], \quad
    \frac{\partial z_v}{\partial b_g} = \hat C[\ell\times]
    \ (\omega = \tilde\omega - b_g).

Without a lever arm the models are linear (:math:`H = [I\ 0]` blocks) and declare the rows
they read (``Measurement.reads``, ``selects``: the square-root sigma-point filters then take
the Kalman update through the position / velocity columns of their factor,
:mod:`estimators.structured`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimators import Measurement, Noise
from nav.quaternion import skew
from nav.strapdown import dcm_unit

Array = NDArray[np.float64]

__all__ = ["InsLayout", "gnss_measurement"]


class InsLayout(NamedTuple):
    """Where the navigation states sit: ambient columns of p, v, q and tangent columns of
    δp, δv, δθ and the gyro bias; ``dim`` is the tangent dimension."""

    dim: int
    p: slice = slice(0, 3)
    v: slice = slice(3, 6)
    q: slice = slice(6, 10)
    tp: slice = slice(0, 3)
    tv: slice = slice(3, 6)
    tth: slice = slice(6, 9)
    tbg: slice = slice(9, 12)
    bg: slice = slice(10, 13)


def gnss_measurement(layout: InsLayout, *, position_sigma: ArrayLike | None = None,
                     velocity_sigma: ArrayLike | None = None, lever_arm: ArrayLike | None = None,
                     body_rate: ArrayLike | None = None) -> Measurement:
    """A GNSS position (``position_sigma``), velocity (``velocity_sigma``) or position +
    velocity measurement (both; σ a scalar or per axis), optionally at ``lever_arm``
    (module docstring; the velocity with a lever arm needs the raw ``body_rate``)."""
    if position_sigma is None and velocity_sigma is None:
        raise ValueError("a GNSS measurement needs a position or a velocity sigma")
    arm = None if lever_arm is None or not np.any(lever_arm) else np.asarray(lever_arm, float)
    if arm is not None and velocity_sigma is not None and body_rate is None:
        raise ValueError("a velocity with a lever arm needs the body rate")
    w = None if body_rate is None else np.asarray(body_rate, dtype=np.float64)
    parts, sig = [], []
    if position_sigma is not None:
        parts.append("p")
        sig.append(np.broadcast_to(np.asarray(position_sigma, float), (3,)))
    if velocity_sigma is not None:
        parts.append("v")
        sig.append(np.broadcast_to(np.asarray(velocity_sigma, float), (3,)))
    L = layout

    def rate(X: Array) -> Array:
        return w - X[..., L.bg]  # type: ignore[operator]

    def h(X: Array) -> Array:
        out = []
        C = dcm_unit(X[..., L.q]) if arm is not None else None
        for part in parts:
            if part == "p":
                z = X[..., L.p]
                out.append(z if C is None else z + C @ arm)
            else:
                z = X[..., L.v]
                if C is not None:
                    z = z + np.einsum("...ij,...j->...i", C, np.cross(rate(X), arm))
                out.append(z)
        return np.concatenate(out, axis=-1)

    def jacobian(x: Array) -> Array:
        H = np.zeros((3 * len(parts), L.dim))
        C = dcm_unit(x[L.q]) if arm is not None else None
        for i, part in enumerate(parts):
            rows = slice(3 * i, 3 * i + 3)
            if part == "p":
                H[rows, L.tp] = np.eye(3)
                if C is not None:
                    H[rows, L.tth] = -C @ skew(arm)
            else:
                H[rows, L.tv] = np.eye(3)
                if C is not None:
                    H[rows, L.tth] = -C @ skew(np.cross(rate(x), arm))
                    H[rows, L.tbg] = C @ skew(arm)
        return H

    reads = None if arm is not None else _rows_read(L, parts)
    return Measurement(h, Noise.from_sigmas(np.concatenate(sig)), jacobian=jacobian,
                       reads=reads, selects=reads is not None)


def _rows_read(L: InsLayout, parts: list[str]) -> tuple[int, ...] | None:
    """The coordinates a measurement without a lever arm reads, when its ambient and
    tangent columns coincide (else ``None``: no declaration)."""
    rows: list[int] = []
    for amb, tan in ((L.p, L.tp) if part == "p" else (L.v, L.tv) for part in parts):
        if amb != tan:
            return None
        rows.extend(range(amb.start, amb.stop))
    return tuple(rows)
