"""Time one star-sensor cycle (25 gyro propagations + 1 star update) per filter.

[Wang SRCKF-SLAM]'s Table 2 gives the time of one iteration of its MATLAB filters (SRCKF 0.012 s,
SRUKF 0.036 s, SRCDKF 0.028 s).  This runs each filter over a simulated log of the
``star-sensor`` world in one process with one BLAS thread, times every cycle, and
prints one JSON object with the median per cycle and the ratio to the paper::

    {"world": "star-sensor", "cycles": 1200, "repeats": 3,
     "filters": {"srckf": {"median_cycle_s": 0.0007, "paper_s": 0.012,
                           "paper_over_ours": 17.1}, ...},
     "srckf_ratio_paper_over_ours": 17.1}

Usage: ``python -m benchmarks.star_sensor_speed [--filters srckf,srukf,srcdkf,ekf]
[--repeats 3] [--world star-sensor]``.
"""

from __future__ import annotations

import benchmarks.single_thread  # noqa: F401  (before numpy: one BLAS thread)

# isort: split
import argparse
import json
import platform
import time

import numpy as np

from slam.kinds.attitude.run import (
    STATE,
    initial_belief,
    interval_transition,
    sim_config,
    star_measurement,
    star_observation,
)
from slam.kinds.attitude.simulate import simulate_attitude
from slam.registry import load_world


def cycle_times(world, name: str, repeats: int, seed: int = 0) -> np.ndarray:
    """Wall time of every predict + update cycle over ``repeats`` passes of one log."""
    log = simulate_attitude(sim_config(world), np.random.default_rng(seed))
    fs = world.filters
    x0, P0 = initial_belief(world, log)
    trans = interval_transition(log.samples_per_star, log.dt, fs.arw_rad_sqrt_s,
                                fs.bias_rw_rad_s_sqrt_s)
    meas = star_measurement(world.star.mode, fs.star_sigma_rad, log.star_refs)
    flt = fs.make(name)
    out = []
    for _ in range(repeats):
        belief = flt.init(x0, STATE, cov=P0)
        belief, _ = flt.update(belief, meas, star_observation(log, 0))
        for j in range(1, log.n_star):
            t0 = time.perf_counter()
            belief = flt.predict(belief, trans, log.gyro_block(j - 1))
            belief, _ = flt.update(belief, meas, star_observation(log, j))
            out.append(time.perf_counter() - t0)
    return np.array(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--world", default="star-sensor")
    ap.add_argument("--filters", default="srckf,srukf,srcdkf,ekf")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover
        pass
    world = load_world(args.world)
    paper = (world.paper.get("filters") or {})
    rows = {}
    n_cycles = 0
    for name in [f.strip() for f in args.filters.split(",") if f.strip()]:
        t = cycle_times(world, name, args.repeats)
        n_cycles = len(t) // args.repeats
        row = {"median_cycle_s": float(np.median(t)), "p90_cycle_s": float(np.quantile(t, 0.9))}
        ps = (paper.get(name) or {}).get("time_per_iteration_s")
        if ps is not None:
            row["paper_s"] = float(ps)
            row["paper_over_ours"] = float(ps) / row["median_cycle_s"]
        rows[name] = row
    out = {"world": world.name, "cycles": n_cycles, "repeats": args.repeats,
           "cycle": "25 gyro propagations (one batched transition) + 1 star update",
           "python": platform.python_version(), "machine": platform.machine(),
           "filters": rows}
    if "paper_over_ours" in rows.get("srckf", {}):
        out["srckf_ratio_paper_over_ours"] = rows["srckf"]["paper_over_ours"]
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
