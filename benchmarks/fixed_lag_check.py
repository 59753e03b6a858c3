"""GTSAM's fixed-lag smoother (the ``fls-<lag>s`` rows, ``BatchFixedLagSmoother``) beside a
window that relinearises the map, on one planar run: how far GTSAM's linearisation points
drift from its estimates, and both windows' NEES/3, landmark error and CPU per epoch.

    python -m benchmarks.fixed_lag_check [--world benchmarks/worlds/webmap-online.toml]
        [--run-seed 1] [--lags 2,20]

GTSAM's smoother keeps, with its default ``enforceConsistency`` (not settable from
Python), the linearisation point each variable had when a marginal factor first touched
it, in every factor on it - here the whole map: a first-estimates linearisation of the
window.  The other choice, every factor but the marginal priors relinearised at each
epoch, is :class:`Window` here.  Prints JSON: per lag, each window's NEES/3 (mean over the
epochs after the first), landmark RMSE and CPU ms per epoch (``time.process_time``, one
BLAS thread), and GTSAM's median / largest landmark distance to its linearisation points
every 200 epochs.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import deque
from typing import Any

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X
from numpy.typing import NDArray

from estimators import wrap_angle
from estimators.threads import single_thread_blas
from slam.kinds.planar.log import PlanarLog
from slam.kinds.planar.online import (
    FLS_RELATIVE_TOL,
    OnlineTrack,
    at_filter_epochs,
    final_map,
    fixed_lag_planar,
)
from slam.kinds.planar.reference import (
    DEFAULT_LATERAL_SIGMA_M,
    epoch_factors,
    graph_inputs,
    obs_noise_model,
)


class Window:
    r"""A relinearising fixed-lag window: its factors (nonlinear, plus the linear priors of
    marginalised poses), its values, and its poses with their times.

    After an epoch's factors are added, LM solves the window from the previous estimate;
    then every pose older than :math:`t_k - \lambda` is marginalised: the factors on it are
    linearised at the current estimate and it is eliminated,
    :math:`p(A, B) = p(A \mid B)\,p(B)` (``eliminatePartialSequential``); :math:`p(B)` on
    its Markov blanket (the next pose, the landmarks it saw) stays as a linear prior
    (``LinearContainerFactor``: Jacobian fixed at that point, residual moved with the
    estimate).  Every other factor - the map's sightings included - is relinearised at
    each solve: the opposite of GTSAM's ``enforceConsistency``."""

    def __init__(self, params: gtsam.LevenbergMarquardtParams):
        self.params = params
        self.values = gtsam.Values()
        self._factors: dict[int, gtsam.NonlinearFactor] = {}
        self._on_key: dict[int, set[int]] = {}
        self._poses: deque[tuple[float, int]] = deque()
        self._next = 0

    def _add(self, factor: gtsam.NonlinearFactor) -> None:
        i = self._next
        self._next += 1
        self._factors[i] = factor
        for key in factor.keys():
            self._on_key.setdefault(int(key), set()).add(i)

    def add(self, factors: gtsam.NonlinearFactorGraph, values: gtsam.Values,
            pose_key: int, t: float) -> None:
        """An epoch's new factors and variables; ``pose_key`` is its pose, stamped ``t``."""
        for i in range(factors.size()):
            self._add(factors.at(i))
        self.values.insert(values)
        self._poses.append((t, pose_key))

    def graph(self) -> gtsam.NonlinearFactorGraph:
        g = gtsam.NonlinearFactorGraph()
        for f in self._factors.values():
            g.push_back(f)
        return g

    def solve(self) -> gtsam.NonlinearFactorGraph:
        """LM over the window from the current values; -> the window's graph."""
        g = self.graph()
        self.values = gtsam.LevenbergMarquardtOptimizer(g, self.values, self.params).optimize()
        return g

    def marginalise_before(self, t: float) -> None:
        """Marginalise every pose stamped before ``t`` (class docstring)."""
        keys = []
        while self._poses and self._poses[0][0] < t:
            keys.append(self._poses.popleft()[1])
        if not keys:
            return
        ids = sorted(set().union(*(self._on_key.get(k, set()) for k in keys)))
        removed = gtsam.NonlinearFactorGraph()
        for i in ids:
            removed.push_back(self._factors[i])
        order = gtsam.Ordering()
        for k in keys:
            order.push_back(k)
        _, rest = removed.linearize(self.values).eliminatePartialSequential(order)
        for i in ids:
            for key in self._factors.pop(i).keys():
                self._on_key[int(key)].discard(i)
        for k in keys:
            del self._on_key[k]
            self.values.erase(k)
        for j in range(rest.size()):
            f = rest.at(j)
            if f is not None and not f.empty():
                self._add(gtsam.LinearContainerFactor(f, self.values))


def relinearised_window(log: PlanarLog, filter_steps: NDArray[np.int64], lag_s: float, *,
                     lateral_sigma_m: float = DEFAULT_LATERAL_SIGMA_M,
                     landmark_cov: bool = False) -> OnlineTrack:
    """A fixed-lag window of ``lag_s`` seconds whose every factor but the marginal priors
    is relinearised at every epoch (:class:`Window`): its current pose and marginal after
    every epoch, its map at the end."""
    t0 = time.perf_counter()
    g = graph_inputs(log, lateral_sigma_m)
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(FLS_RELATIVE_TOL)
    window = Window(params)
    E = len(g.steps)
    poses, covs = np.empty((E, 3)), np.empty((E, 3, 3))
    seen: set[int] = set()
    pose_est = gtsam.Pose2(*np.asarray(log.x0, dtype=float))
    by_step, obs_noise = log.observations_at(), obs_noise_model(log.obs_cov)
    marginals = None
    for e in range(E):
        k = int(g.steps[e])
        new_f, new_v, pose_est = epoch_factors(log, g, e, pose_est, seen, by_step, obs_noise)
        t_k = k * log.dt
        window.add(new_f, new_v, X(k), t_k)
        graph = window.solve()
        pose_est = window.values.atPose2(X(k))
        poses[e] = (pose_est.x(), pose_est.y(), pose_est.theta())
        marginals = gtsam.Marginals(graph, window.values)
        covs[e] = marginals.marginalCovariance(X(k))
        if e < E - 1:
            window.marginalise_before(t_k - float(lag_s))
    assert marginals is not None  # E >= 1: a log has its first epoch
    ids, lms, lm_cov = final_map(window.values, marginals.marginalCovariance, seen,
                                 landmark_cov)
    p_f, c_f = at_filter_epochs(log, g.steps, filter_steps, poses, covs, lateral_sigma_m)
    return OnlineTrack(f"window-{lag_s:g}s", p_f, c_f, ids, lms, lm_cov,
                       time.perf_counter() - t0)


def _nees3(poses: np.ndarray, cov: np.ndarray, truth: np.ndarray) -> float:
    err = poses - truth
    err[:, 2] = wrap_angle(err[:, 2])
    return float(np.mean(np.einsum("ei,eij,ej->e", err[1:], np.linalg.inv(cov[1:]),
                                   err[1:])) / 3.0)


def _drift_recorder(drift: list[dict[str, float]]):
    """An ``on_epoch`` hook appending, every 200 epochs, the median and largest distance of
    the landmark estimates to GTSAM's linearisation points to ``drift``."""
    def record(e: int, smoother, estimate, seen: set[int]) -> None:
        if seen and e % 200 == 0:
            lin = smoother.getLinearizationPoint()
            d = [float(np.linalg.norm(estimate.atPoint2(L(j)) - lin.atPoint2(L(j))))
                 for j in sorted(seen)]
            drift.append({"epoch": e, "median_m": float(np.median(d)), "max_m": max(d)})
    return record


def check(world_path: str, run_seed: int, lags: list[float]) -> dict[str, Any]:
    """Both windows at each lag on the run of ``world_path`` seeded ``run_seed``."""
    from slam.kinds.planar.simulate import simulate_planar
    from slam.registry import load_world

    log = simulate_planar(load_world(world_path), np.random.default_rng(run_seed))
    steps = graph_inputs(log).steps
    truth = log.truth[steps]
    out: dict[str, Any] = {"world": world_path, "run_seed": run_seed, "epochs": len(steps),
                           "lags": []}
    for lag in lags:
        drift: list[dict[str, float]] = []
        row: dict[str, Any] = {"lag_s": lag}
        for name in ("gtsam_fls", "relinearised_window"):
            t = time.process_time()
            track = (fixed_lag_planar(log, steps, lag, on_epoch=_drift_recorder(drift))
                     if name == "gtsam_fls" else relinearised_window(log, steps, lag))
            cpu = time.process_time() - t
            err = np.linalg.norm(track.landmarks - log.landmarks[track.landmark_ids], axis=1)
            row[name] = {"nees3": _nees3(track.poses, track.pose_cov, truth),
                         "landmark_rmse_m": float(np.sqrt(np.mean(err**2))),
                         "cpu_ms_per_epoch": 1e3 * cpu / len(steps)}
        row["gtsam_fls"]["landmark_to_linearisation_point"] = drift
        out["lags"].append(row)
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="benchmarks/worlds/webmap-online.toml")
    ap.add_argument("--run-seed", type=int, default=1)
    ap.add_argument("--lags", default="2,20")
    a = ap.parse_args(argv)
    with single_thread_blas():
        print(json.dumps(check(a.world, a.run_seed, [float(x) for x in a.lags.split(",")]),
                         indent=1))


if __name__ == "__main__":
    main()
