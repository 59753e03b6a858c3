"""``python -m benchmarks.joint_structure``: joint-mode planar SLAM filters with the dense
sigma-point steps and with the structured ones (:mod:`estimators.structured`), in one
process, one maths thread: CPU seconds, their ratio, and the worst difference of the results.

For each world the same simulated logs go through every filter four ways - dense and
structured steps, each per run and batched (:func:`slam.kinds.planar.slam.run_slam_batch`) -
alternating the order ``--reps`` times; the figures are CPU seconds of this process
(``time.process_time``) spent in the filter loops alone (no simulation, smoother or scoring).
The difference reported is the largest relative difference of the structured results from
the dense ones over poses, vehicle covariances, landmark means and covariances and NIS
(relative to each array's largest magnitude).

Defaults: ``webmap`` and ``bailey``, 10 runs, the filters ``ekf,srckf,srckf-inv``; e.g.
``--worlds webmap --runs 100``.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from contextlib import nullcontext

import numpy as np

from estimators.threads import single_thread_blas


def _logs(world_name: str, runs: int) -> tuple[object, list]:
    from slam.kinds.planar.simulate import simulate_planar
    from slam.registry import load_world

    world = load_world(world_name)
    seeds = np.random.SeedSequence(world.seed).spawn(runs)
    return world, [simulate_planar(world, np.random.default_rng(s)) for s in seeds]


def _run(world, logs: list, name: str, batched: bool, dense: bool) -> tuple[float, list]:
    from estimators.structured import dense_steps
    from slam.kinds.planar.slam import run_slam_batch

    fs = world.filters
    with dense_steps() if dense else nullcontext():
        t0 = time.process_time()
        out = run_slam_batch(logs, name, association=fs.association,
                             gates=(fs.gate_accept, fs.gate_new),
                             epoch_steps=world.sensor.period_steps, mode="joint",
                             filter_params=fs.settings_of(name), batched=batched)
        return time.process_time() - t0, out


def _worst(a: list, b: list) -> float:
    worst = 0.0
    for ra, rb in zip(a, b):
        if ra.diverged != rb.diverged or ra.failure != rb.failure:
            return float("inf")
        for x, y in ((ra.poses, rb.poses), (ra.pose_cov, rb.pose_cov),
                     (ra.landmarks, rb.landmarks), (ra.landmark_cov, rb.landmark_cov),
                     (ra.nis, rb.nis)):
            x, y = np.asarray(x), np.asarray(y)
            if x.shape != y.shape or not np.array_equal(np.isnan(x), np.isnan(y)):
                return float("inf")
            ok = ~np.isnan(y)
            if ok.any():
                scale = max(float(np.max(np.abs(y[ok]))), 1e-300)
                worst = max(worst, float(np.max(np.abs(x[ok] - y[ok]))) / scale)
    return worst


def measure(world_name: str, runs: int, filters: list[str], reps: int) -> dict:
    """Every filter four ways, ``reps`` times alternating; CPU seconds, ratios, worst
    difference."""
    from estimators.structured import FALLBACKS

    world, logs = _logs(world_name, runs)
    ways = [(b, d) for b in (False, True) for d in (True, False)]
    cpu = {f"{'batched' if b else 'per-run'}/{'dense' if d else 'structured'}": 0.0
           for b, d in ways}
    worst: dict[str, float] = {}
    per_filter: dict[str, dict[str, float]] = {}
    FALLBACKS.clear()
    for name in filters:
        results = {}
        mine = per_filter.setdefault(name, dict.fromkeys(cpu, 0.0))
        for rep in range(reps):
            for b, d in (ways if rep % 2 == 0 else ways[::-1]):
                key = f"{'batched' if b else 'per-run'}/{'dense' if d else 'structured'}"
                seconds, results[key] = _run(world, logs, name, b, d)
                cpu[key] += seconds / reps
                mine[key] += seconds / reps
        ref = results["per-run/dense"]
        worst[name] = max(_worst(results[k], ref) for k in results if k != "per-run/dense")
    base = cpu["per-run/dense"]
    return {"world": world_name, "runs": runs, "filters": filters, "reps": reps,
            "cpu_s": {k: round(v, 3) for k, v in cpu.items()},
            "ratio_over_per_run_dense": {k: round(base / v, 3) for k, v in cpu.items()},
            "per_filter_cpu_s": {f: {k: round(v, 3) for k, v in c.items()} for f, c in
                                 per_filter.items()},
            "worst_relative_difference": worst, "fallbacks": dict(FALLBACKS)}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.joint_structure", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--worlds", default="webmap,bailey", help="comma-separated planar worlds")
    p.add_argument("--runs", type=int, default=10)
    p.add_argument("--filters", default="ekf,srckf,srckf-inv")
    p.add_argument("--reps", type=int, default=1, help="alternating repetitions")
    args = p.parse_args(argv)
    out = {"python": platform.python_version(), "machine": platform.machine(), "cases": []}
    with single_thread_blas():
        for name in args.worlds.split(","):
            out["cases"].append(measure(name, args.runs, args.filters.split(","), args.reps))
            print(json.dumps(out["cases"][-1]), file=sys.stderr)
    json.dump(out, sys.stdout, indent=2)
    print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
