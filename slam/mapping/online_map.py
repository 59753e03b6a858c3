r"""The online optimum's map over time (row ``isam2``'s landmark scores, like a filter's
:class:`~slam.mapping.map_series.MapSeries`; planar and drone kinds), sampled every
:data:`ONLINE_MAP_STRIDE`-th graph epoch.

At a sampled epoch :math:`k` every landmark in the graph gives iSAM2's estimate
:math:`\hat l_{j|k}` and marginal covariance :math:`P_{j|k}`
(``marginalCovariance(L(j))``), hence its squared error and its NEES
:math:`(\hat l_{j|k} - l_j)^\top P_{j|k}^{-1} (\hat l_{j|k} - l_j)` (``d`` = 2 or 3 dof,
the landmarks' dimension).  The sums go to
the filter epoch of that graph epoch; every other epoch holds NaN (``nees_count`` 0), so
:func:`slam.scoring.landmark_anees_entries` averages over the sampled epochs only.  Why
sampled: one landmark marginal costs about 150 µs, so every landmark at every epoch is
about five times the online pass itself on webmap (5.6 s against 1.06 s a run, measured);
every 10th epoch adds about half the pass.  Landmark ``j`` of the graph is ``L(j)``, the
``j``-th row of the true map.
"""

from __future__ import annotations

import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L
from numpy.typing import NDArray

from estimators.consistency import nees_series
from slam.mapping.map_series import MapSeries

Array = NDArray[np.float64]

#: The online row's map is scored at every ONLINE_MAP_STRIDE-th graph epoch and the last.
ONLINE_MAP_STRIDE = 10


class MapSampler:
    """Collects the online map's scores (module docstring) at the sampled graph epochs
    of a pass over ``n_graph`` epochs, against the true map ``truth`` (M, 2) or (M, 3);
    ``seconds`` is the time it took (scoring, which an estimator's time leaves out)."""

    def __init__(self, truth: Array, n_graph: int, stride: int = ONLINE_MAP_STRIDE):
        if stride < 1:
            raise ValueError(f"stride must be >= 1, got {stride}")
        self.truth = np.asarray(truth, dtype=float)
        self.n_graph, self.stride = n_graph, stride
        self.values = np.full((6, n_graph), np.nan)
        self.dim = self.truth.shape[1]
        self.seconds = 0.0

    def wants(self, e: int) -> bool:
        return e % self.stride == 0 or e == self.n_graph - 1

    def record(self, e: int, isam: gtsam.ISAM2) -> None:
        """The map's scores after graph epoch ``e``'s update (if ``e`` is sampled)."""
        if not self.wants(e):
            return
        t0 = time.perf_counter()
        self._score(e, isam)
        self.seconds += time.perf_counter() - t0

    def _score(self, e: int, isam: gtsam.ISAM2) -> None:
        ids = [j for j in range(len(self.truth)) if isam.valueExists(L(j))]
        n = len(ids)
        if n == 0:
            self.values[:, e] = (0, 0, 0.0, 0.0, 0, 0.0)
            return
        point = (isam.calculateEstimatePoint2 if self.dim == 2
                 else isam.calculateEstimatePoint3)
        est = np.array([point(L(j)) for j in ids], dtype=float)
        cov = np.array([isam.marginalCovariance(L(j)) for j in ids], dtype=float)
        err = est - self.truth[ids]
        nees = nees_series(err, cov)  # the filters' landmark NEES (MapSeries)
        ok = np.isfinite(nees)
        self.values[:, e] = (n, n, float(np.sum(err**2)), float(np.sum(nees[ok])),
                             int(ok.sum()), float(np.trace(cov, axis1=1, axis2=2).sum()))

    def series(self, graph_steps: NDArray[np.int64], filter_steps: NDArray[np.int64]
               ) -> MapSeries:
        """The sampled scores at the filter epochs (NaN, count 0 elsewhere)."""
        index = np.searchsorted(np.asarray(filter_steps), np.asarray(graph_steps))
        out = np.full((6, len(filter_steps)), np.nan)
        out[:, index] = self.values
        f32 = out.astype(np.float32)
        count = np.nan_to_num(f32[4], nan=0.0)
        return MapSeries(n=f32[0], scored=f32[1], sq_err=f32[2], nees=f32[3],
                         nees_count=count, trace=f32[5], dof=self.dim)
