"""Per-epoch summaries of a SLAM filter's map, taken inside the filter loop.

A run's figures need the map's state over time (how many landmarks the filter carries,
how uncertain its map is, how wrong and how consistent its landmarks are), not only the
final map.  :class:`MapSeries` keeps five numbers per epoch instead of every landmark's
mean and covariance, so a Monte Carlo worker returns a few kilobytes per run.

:class:`MapRecorder` computes them from the belief at each recorded epoch, vectorised over
the landmarks (the 2x2 / 3x3 diagonal blocks straight from the square-root factor's rows,
never the joint covariance), and times itself so that the filter loop's reported time
can leave it out.  Numerical trouble here never reaches the filter loop: a degenerate
block gives NaN, not an exception.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from estimators.consistency import nees_2d_entries
from estimators.linalg import Array
from estimators.models import Belief, SqrtGaussian
from estimators.partitioned import BlockLayout
from slam.scoring import nees_series


@dataclass(frozen=True)
class MapSeries:
    """The map of one filter run, per epoch (E,).

    n : landmarks in the state; scored : of those, landmarks with a known true position;
    sq_err : sum over the scored landmarks of the squared position error (m²);
    nees : sum over the scored landmarks of their NEES (``landmark_dim`` dof each) and
    nees_count : how many landmarks that sum holds (blocks too ill-conditioned are left
    out); trace : trace of the map's covariance (m²), every landmark in the state.
    Epochs after a divergence are NaN.  Stored in single precision (figures only).
    """

    n: Array
    scored: Array
    sq_err: Array
    nees: Array
    nees_count: Array
    trace: Array
    dof: int


def _landmark_blocks(b: Belief, start: int, n_lm: int, dim: int) -> Array:
    """The (n_lm, dim, dim) diagonal covariance blocks of the landmarks."""
    stop = start + n_lm * dim
    if isinstance(b, SqrtGaussian):
        S = b.sqrt[start:stop].reshape(n_lm, dim, -1)
        return np.einsum("lik,ljk->lij", S, S)
    C = b.cov[start:stop, start:stop].reshape(n_lm, dim, n_lm, dim)
    idx = np.arange(n_lm)
    return C[idx, :, idx, :]


class MapRecorder:
    """Fills a :class:`MapSeries` epoch by epoch (:meth:`record`), then :meth:`series`."""

    def __init__(self, layout: BlockLayout, n_epochs: int, true_landmarks: Array | None):
        self.layout, self.truth = layout, true_landmarks
        self.values = np.full((6, n_epochs), np.nan)
        self.seconds = 0.0

    def record(self, e: int, b: Belief, slot_ids: list[int]) -> None:
        """Summarise the map of belief ``b`` at epoch ``e`` (``slot_ids``: the true id of
        each state slot, ``-1`` where unknown)."""
        t0 = time.perf_counter()
        try:
            with np.errstate(all="ignore"):
                self.values[:, e] = self._summary(b, np.asarray(slot_ids, dtype=int))
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            self.values[:, e] = np.nan
        self.seconds += time.perf_counter() - t0

    def _summary(self, b: Belief, ids: Array) -> list[float]:
        lay = self.layout
        n_lm, na, nd = len(ids), lay.landmark_ambient, lay.landmark_dim
        if n_lm == 0:
            return [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        blocks = _landmark_blocks(b, lay.vehicle_dim, n_lm, nd)
        trace = float(np.trace(blocks, axis1=1, axis2=2).sum())
        known = ids >= 0
        if self.truth is not None:
            known &= ids < len(self.truth)
        if self.truth is None or not known.any() or na != nd:
            return [float(n_lm), 0.0, np.nan, np.nan, 0.0, trace]
        means = b.mean[lay.vehicle_ambient:lay.vehicle_ambient + n_lm * na].reshape(n_lm, na)
        err = means[known] - self.truth[ids[known]]
        nees = nees_series(err, blocks[known])
        finite = np.isfinite(nees)
        return [float(n_lm), float(known.sum()), float(np.sum(err**2)),
                float(nees[finite].sum()), float(finite.sum()), trace]

    def series(self) -> MapSeries:
        """The recorded series (single precision: they only feed figures)."""
        n, scored, sq, nees, count, trace = self.values.astype(np.float32)
        return MapSeries(n, scored, sq, nees, count, trace, self.layout.landmark_dim)


class BatchMapRecorder:
    """:class:`MapRecorder` for a batch of runs with one layout (the same slots and ids):
    one summary per member per epoch, computed for every member at once."""

    def __init__(self, layout: BlockLayout, n_runs: int, n_epochs: int,
                 true_landmarks: Array | None):
        self.layout, self.truth = layout, true_landmarks
        self.values = np.full((n_runs, 6, n_epochs), np.nan)
        self.seconds = 0.0

    def record(self, e: int, b: Belief, live: Array, slot_ids: list[int]) -> None:
        """Summarise the maps of the batch ``b`` (members ``live``) at epoch ``e``."""
        t0 = time.perf_counter()
        try:
            with np.errstate(all="ignore"):
                self.values[live, :, e] = self._summary(b, np.asarray(slot_ids, dtype=int))
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            self.values[live, :, e] = np.nan
        self.seconds += time.perf_counter() - t0

    def _summary(self, b: Belief, ids: Array) -> Array:
        lay = self.layout
        B = b.mean.shape[0]
        n_lm, na, nd = len(ids), lay.landmark_ambient, lay.landmark_dim
        out = np.zeros((B, 6))
        if n_lm == 0:
            return out
        start, stop = lay.vehicle_dim, lay.vehicle_dim + n_lm * nd
        if isinstance(b, SqrtGaussian):  # entry by entry: one pass over the rows each
            S = b.sqrt[:, start:stop].reshape(B, n_lm, nd, -1)
            blocks = np.empty((B, n_lm, nd, nd))
            for i in range(nd):
                for j in range(i + 1):
                    blocks[..., i, j] = np.einsum("blk,blk->bl", S[:, :, i], S[:, :, j])
                    blocks[..., j, i] = blocks[..., i, j]
        else:
            C = b.cov[:, start:stop, start:stop].reshape(B, n_lm, nd, n_lm, nd)
            idx = np.arange(n_lm)
            blocks = C[:, idx, :, idx, :].transpose(1, 0, 2, 3)
        out[:, 0] = n_lm
        out[:, 5] = np.trace(blocks, axis1=2, axis2=3).sum(axis=1)
        known = ids >= 0
        if self.truth is not None:
            known &= ids < len(self.truth)
        if self.truth is None or not known.any() or na != nd:
            out[:, 2:4] = np.nan
            return out
        means = b.mean[:, lay.vehicle_ambient:lay.vehicle_ambient + n_lm * na
                       ].reshape(B, n_lm, na)
        every = bool(known.all())  # (no copies of the blocks then)
        err = (means if every else means[:, known]) - self.truth[ids[known]]
        k = int(known.sum())
        if nd == 2:  # nees_series' closed form, on the (B, k) entries
            P = blocks if every else blocks[:, known]
            e0, e1 = err[..., 0], err[..., 1]
            nees = nees_2d_entries(e0, e1, P[..., 0, 0], 0.5 * (P[..., 0, 1] + P[..., 1, 0]),
                                   P[..., 1, 1])
            nees[~(np.isfinite(e0) & np.isfinite(e1))] = np.nan
        else:
            nees = nees_series(err.reshape(B * k, nd), blocks[:, known].reshape(B * k, nd, nd)
                               ).reshape(B, k)
        finite = np.isfinite(nees)
        out[:, 1] = k
        out[:, 2] = np.sum(err**2, axis=(1, 2))
        out[:, 3] = np.where(finite, nees, 0.0).sum(axis=1)
        out[:, 4] = finite.sum(axis=1)
        return out

    def series(self, run: int, epochs: int | None = None) -> MapSeries:
        """Member ``run``'s recorded series over its first ``epochs`` (single precision)."""
        n, scored, sq, nees, count, trace = self.values[run, :, :epochs].astype(np.float32)
        return MapSeries(n, scored, sq, nees, count, trace, self.layout.landmark_dim)


def vehicle_variances(b: Belief, dim: int) -> Array:
    """Variances of the first ``dim`` tangent coordinates (the vehicle's)."""
    if isinstance(b, SqrtGaussian):
        return np.sum(b.sqrt[:dim] ** 2, axis=1)
    return np.diagonal(b.cov)[:dim].copy()
