"""Time the ``ship`` estimators: one cycle per filter and treatment, and one whole run.

One cycle is the prediction through one vector interval's gyro samples (100 at 1 Hz)
plus one update with both vectors (for the pseudo-observation treatments the model is
built anew from the prior each time).  Each estimator runs over the same simulated logs
in this process with one BLAS thread; wall time of the cycles (as the campaign reports
it) and CPU time of the whole filter run are given, and the CPU time of one complete
``run_once`` (simulation, every estimator of the world, the GTSAM smoother with
marginals, scoring) - the number that sets the campaign's wall time on idle cores
(``runs x cpu_per_run_s / workers``).  Prints one JSON object::

    {"world": "ship", "logs": 3, "estimators": {"hommukf": {"treatment": "paper",
     "median_cycle_ms": ..., "cpu_per_run_s": ...}, ...},
     "run_once_cpu_s": ..., "campaign_estimate_s": {"runs": 50, "workers": 2, ...}}

Usage: ``python -m benchmarks.ship_speed [--logs 3] [--world ship]`` (registers the
``ship`` kind itself).  On a loaded machine CPU times are less disturbed than wall
times, but both grow with the load.
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

from slam.kinds.ship import KIND
from slam.kinds.ship.models import (
    earth_rate_transition,
    treatment,
    vector_measurement,
)
from slam.kinds.ship.run import estimators, initial_belief, run_filter, run_once
from slam.kinds.ship.simulate import simulate_ship
from slam.registry import load_world, register


def estimator_times(world, logs: int) -> dict[str, dict]:
    """Per estimator: median cycle wall time and CPU time per run over ``logs`` logs."""
    g = world.gyro
    cycle: dict[str, list[float]] = {}
    cpu: dict[str, list[float]] = {}
    kinds: dict[str, str] = {}
    for seed in range(logs):
        log = simulate_ship(world, np.random.default_rng(seed))
        x0, P0 = initial_belief(world, log)
        trans = earth_rate_transition(log.samples_per_update, log.dt, g.arw_rad_sqrt_s,
                                      g.bias_rw_rad_s_sqrt_s, log.earth_rate)
        vec = vector_measurement(log)
        for name, t, main in estimators(world, world.filters.names):
            c0 = time.process_time()
            s = run_filter(log, name, treatment(t), x0, P0, trans, vec, main)
            cpu.setdefault(s.name, []).append(time.process_time() - c0)
            cycle.setdefault(s.name, []).append(s.time_s / max(s.cycles, 1))
            kinds[s.name] = t
    return {n: {"treatment": kinds[n], "median_cycle_ms": 1e3 * float(np.median(cycle[n])),
                "cpu_per_run_s": float(np.mean(cpu[n]))} for n in cycle}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--world", default="ship")
    ap.add_argument("--logs", type=int, default=3)
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
    register(KIND)
    world = load_world(args.world)
    rows = estimator_times(world, args.logs)
    runs = []
    for seed in range(args.logs):
        c0 = time.process_time()
        run_once(world, seed, np.random.SeedSequence(seed), list(world.filters.names))
        runs.append(time.process_time() - c0)
    per_run = float(np.mean(runs))
    out = {"world": world.name, "logs": args.logs,
           "cycle": f"{world.samples_per_update} gyro samples (one batched transition) + "
                    "1 update with both vectors",
           "python": platform.python_version(), "machine": platform.machine(),
           "load_average": list(os.getloadavg()), "estimators": rows,
           "run_once_cpu_s": per_run,
           "campaign_estimate_s": {"runs": world.runs, "workers": 2,
                                   "cpu_bound_wall_s": per_run * world.runs / 2.0}}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
