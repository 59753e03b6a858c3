"""Time the ``fixed-wing`` campaign's pieces: CPU seconds of one ``run_once`` (simulation,
every filter of the world, the GTSAM smoother with marginals, scoring) and each
estimator's share, over a few runs in this process with one BLAS thread.  The campaign's
wall time on idle cores is about ``runs x run_once_cpu_s / workers``.  Prints one JSON
object::

    {"world": "fixed-wing", "runs": 2, "run_once_cpu_s": ..., "estimators":
     {"ea-ukf": {"cpu_per_run_s": ..., "ms_per_cycle": ...}, ...},
     "campaign_estimate_s": {"runs": 15, "workers": 2, "wall_s": ...}}

Usage: ``python -m benchmarks.fixed_wing_speed [--runs 2] [--world fixed-wing]``.  On a
loaded machine CPU times are less disturbed than wall times, but both grow with the load.
"""

from __future__ import annotations

import benchmarks.single_thread  # noqa: F401  (before numpy: one BLAS thread)

# isort: split
import argparse
import json
import os
import platform
import time

import numpy as np

from slam.kinds.fixed_wing import run as fr
from slam.kinds.fixed_wing.simulate import simulate, truth_of
from slam.registry import load_world


def _cpu(fn, *args):
    t0 = time.process_time()
    out = fn(*args)
    return out, time.process_time() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--world", default="fixed-wing")
    args = ap.parse_args()
    world = load_world(args.world)
    truth_of(world)  # built once per worker process in a campaign
    per: dict[str, list[float]] = {}
    cycles: dict[str, list[float]] = {}
    totals = []
    for r in range(args.runs):
        t_run = time.process_time()
        rng = np.random.default_rng(r)
        log = simulate(world, rng)
        ea0, ins0 = fr.ea_prior(log, rng), fr.ins_prior(log, rng)
        for name in world.filters.names:
            run = fr.run_ea if name.startswith("ea-") else fr.run_ins
            s, cpu = _cpu(run, log, name, *(ea0 if name.startswith("ea-") else ins0))
            per.setdefault(name, []).append(cpu)
            cycles.setdefault(name, []).append(1e3 * s.time_s / max(s.cycles, 1))
        _, cpu = _cpu(fr._reference, log, *ins0)
        per.setdefault("gtsam", []).append(cpu)
        totals.append(time.process_time() - t_run)
    run_cpu = float(np.mean(totals))
    print(json.dumps({
        "world": world.name, "runs": args.runs, "machine": platform.processor() or None,
        "load_average": os.getloadavg()[0], "run_once_cpu_s": run_cpu,
        "estimators": {n: {"cpu_per_run_s": float(np.mean(v)),
                           "ms_per_cycle": float(np.mean(cycles[n])) if n in cycles else None}
                       for n, v in per.items()},
        "campaign_estimate_s": {"runs": world.runs, "workers": 2,
                                "wall_s": world.runs * run_cpu / 2.0}}, indent=1))


if __name__ == "__main__":
    main()
