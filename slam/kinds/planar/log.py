"""Sensor logs: what a run of a vehicle recorded, with the truth when it is known.

A log is the single input both the filters and the GTSAM smoother read, so they see
the very same measurements.  Logs are immutable values and round-trip losslessly
through ``.npz`` files (:func:`save_log`, :func:`load_log`).
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


@dataclass(frozen=True)
class PlanarLog:
    r"""A planar range-bearing SLAM log (car-like vehicle, point landmarks).

    Step ``k`` (``0 <= k <= K``) is the instant ``t[k] = k * dt``.  Between steps
    ``k`` and ``k + 1`` the vehicle applies ``controls[k]`` = noisy ``[V, G]``
    (speed m/s, steer rad) for ``dt`` seconds with the car model

    .. math::

        x' = x + V\\,dt \\cos(G + φ),\\quad y' = y + V\\,dt \\sin(G + φ),\\quad
        φ' = \\mathrm{wrap}(φ + V\\,dt \\sin G / WB).

    Observations ``obs[j] = [range_m, bearing_rad]`` were taken at step
    ``obs_step[j]`` (after the move into that step) of landmark ``obs_id[j]``;
    bearings are relative to the vehicle heading, in ``[-π, π)``.  Observations are
    sorted by step.

    Attributes
    ----------
    dt : float
        Control period (s).
    wheelbase : float
        Wheelbase WB (m).
    x0 : (3,) array
        Initial pose ``[x, y, φ]`` (known to the filters).
    P0 : (3, 3) array
        Initial pose covariance given to the filters (may be zero).
    controls : (K, 2) array
        Noisy controls ``[V, G]`` the filters and the smoother see.
    control_cov : (2, 2) array
        Covariance of the control noise.
    obs_step : (M,) int array
    obs_id : (M,) int array
    obs : (M, 2) array
    obs_cov : (2, 2) array
        Covariance of one ``[range, bearing]`` observation.
    truth : (K + 1, 3) array or None
        True poses at every step; ``None`` for a recorded log without ground truth.
    landmarks : (N, 2) array or None
        True landmark positions, indexed by ``obs_id``; ``None`` when unknown.
    """

    dt: float
    wheelbase: float
    x0: Array
    P0: Array
    controls: Array
    control_cov: Array
    obs_step: NDArray[np.int64]
    obs_id: NDArray[np.int64]
    obs: Array
    obs_cov: Array
    truth: Array | None = None
    landmarks: Array | None = None

    @property
    def n_steps(self) -> int:
        """Number of control steps ``K``."""
        return int(self.controls.shape[0])

    def observations_at(self) -> dict[int, slice]:
        """Map step -> slice of the observations taken at that step."""
        steps, first = np.unique(self.obs_step, return_index=True)
        last = np.append(first[1:], len(self.obs_step))
        return {int(k): slice(int(a), int(b)) for k, a, b in zip(steps, first, last)}


def save_log(log: PlanarLog, path: str | os.PathLike) -> None:
    """Write ``log`` to ``path`` (``.npz``) atomically (temporary file + rename)."""
    path = Path(path)
    arrays = {}
    for f in fields(log):
        value = getattr(log, f.name)
        if value is not None:
            arrays[f.name] = np.asarray(value)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".npz")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_log(path: str | os.PathLike) -> PlanarLog:
    """Read a log written by :func:`save_log`."""
    with np.load(path) as data:
        kwargs = {}
        for f in fields(PlanarLog):
            if f.name in data:
                value = data[f.name]
                kwargs[f.name] = value.item() if value.ndim == 0 else value
        return PlanarLog(**kwargs)
