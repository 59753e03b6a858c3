"""The star-sensor filters over a log: one run (:func:`run_filter`) or many runs at once
as an array axis (:func:`batch_filter`), through the one filter loop
(:func:`estimators.loop.run_epochs` / :func:`estimators.batch.run_batch`); the models are
:mod:`slam.kinds.attitude.run`'s."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from estimators import Euclidean, Measurement, Product, Transition, make_filter
from estimators.batch import run_batch, stack
from estimators.loop import run_epochs
from nav.spaces import UnitQuaternion
from slam.kinds.attitude.simulate import AttitudeLog
from slam.results import Array, EstimateSeries

QUAT = UnitQuaternion()
STATE = Product([QUAT, Euclidean(3)])
"""The state ``[q_nb, b]`` (ambient 7, tangent 6)."""


def star_observation(log: AttitudeLog, j: int) -> Array:
    """The star measurement of epoch ``j`` in the measurement model's ambient form."""
    if log.star_q is not None:
        return log.star_q[j]
    return log.star_vectors[j].ravel()


def run_filter(log: AttitudeLog, name: str, x0: Array, P0: Array, transition: Transition,
               measurement: Measurement, settings: Mapping[str, Any] | None = None
               ) -> EstimateSeries:
    """Run filter ``name`` (built with ``settings``, the world's stated tuning constants:
    :meth:`worlds.common.TunedFilters.settings_of`) over the log: update at t = 0, then
    predict + update per interval (the one filter loop, :func:`estimators.loop.run_epochs`;
    a numerical failure ends the run as ``diverged`` and later epochs stay NaN)."""
    M = log.n_star
    flt = make_filter(name, **(settings or {}))
    means = np.full((M, 7), np.nan)
    covs = np.full((M, 6, 6), np.nan)
    nis = np.full(M, np.nan)

    def record(j: int, b) -> None:
        means[j], covs[j] = b.mean, b.cov

    def correct(j: int, b):
        b, inn = flt.update(b, measurement, star_observation(log, j))
        return b, [inn]

    out = run_epochs(flt, flt.init(x0, STATE, cov=P0), M, correct_first=True, record=record,
                     transition=lambda j, b: (transition, log.gyro_block(j - 1)),
                     correct=correct)
    nis[out.nis_epoch] = out.nis
    return EstimateSeries(name, means, covs, M - 1, nis=nis, nis_dof=measurement.noise.dim,
                          time_s=out.time_s, diverged=out.diverged, failure=out.failure)


def batch_filter(logs: Sequence[AttitudeLog], name: str, beliefs: Sequence[tuple[Array, Array]],
                 transition: Transition, measurement: Measurement,
                 settings: Mapping[str, Any] | None = None) -> list[EstimateSeries]:
    """:func:`run_filter` of every log at once, the runs as an array axis
    (:func:`estimators.batch.run_batch`: each run's series is its per-run one, a failing
    run ends alone with the per-run reason).  The logs share the star epochs and the
    measurement's noise (one world); each has its own gyro samples and star readings."""
    M = logs[0].n_star
    flt = make_filter(name, **(settings or {}))
    B = len(logs)
    means = np.full((B, M, 7), np.nan)
    covs = np.full((B, M, 6, 6), np.nan)
    gyro = np.stack([np.stack([log.gyro_block(j) for j in range(M - 1)]) for log in logs])
    stars = np.stack([np.stack([star_observation(log, j) for j in range(M)]) for log in logs])

    def record(j: int, b, live) -> None:
        means[live, j], covs[live, j] = b.mean, b.cov

    def correct(j: int, b, live):
        b, inn = flt.update(b, measurement, stars[live, j])
        return b, [inn]

    b0 = stack([flt.init(x0, STATE, cov=P0) for x0, P0 in beliefs])
    outs = run_batch(flt, b0, M, correct_first=True, record=record,
                          transition=lambda j, b, live: (transition, gyro[live, j - 1]),
                          correct=correct)
    out = []
    for r, o in enumerate(outs):
        nis = np.full(M, np.nan)
        nis[o.nis_epoch] = o.nis
        out.append(EstimateSeries(name, means[r], covs[r], M - 1, nis=nis,
                                  nis_dof=measurement.noise.dim, time_s=o.time_s,
                                  diverged=o.diverged, failure=o.failure))
    return out
