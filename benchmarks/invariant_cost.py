"""Cost of the invariant SLAM variants (issue #17: at most 1.3x their standard twin): CPU
time per epoch of ``ekf-inv``, ``srckf-inv``, ``srukf-inv`` against ``ekf``, ``srckf``,
``srukf`` on one webmap (or drone) log, in the same process.

Each repetition runs every pair once, alternating the order (twin first on even
repetitions, the variant first on odd ones) so that a drift in the machine's load
falls on both; BLAS runs on one thread.  Prints one JSON object: per pair the CPU seconds
per epoch of each repetition, the per-repetition ratios, their median and minimum, the
ratio of the least times (the runs least disturbed by other jobs), and the 1/5/15-minute
load averages before and after (a shared machine: compare ratios only).

Run ``python -m benchmarks.invariant_cost --reps 3`` (``--mode local``, ``--world drone``
for the drone's variants, ``--loops 1`` for a shorter webmap log,
``--pairs ekf-inv,srckf-inv``); ``python -m benchmarks.consistent_slam --no-webmap
--cost`` prints the same section.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from dataclasses import replace
from typing import Any

import numpy as np

PAIRS = ("ekf-inv", "srckf-inv", "srukf-inv")
TARGET = 1.3


def _cpu_per_epoch(log: Any, name: str, epoch_steps: int, mode: str = "joint"
                   ) -> tuple[float, int]:
    """CPU seconds per epoch of one run of ``name`` on ``log`` (a planar log, or a drone log
    when ``epoch_steps`` is 0), and its epoch count."""
    from slam.kinds.drone.filtering import run_drone_filter
    from slam.kinds.planar.slam import run_slam

    t0 = time.process_time()
    if epoch_steps:
        r = run_slam(log, name, epoch_steps=epoch_steps, mode=mode)
        diverged, failure, epochs = r.diverged, r.failure, len(r.steps) - 1
    else:
        d = run_drone_filter(log, name, mode=mode)
        diverged, failure, epochs = d.diverged, d.failure, d.steps
    if diverged:
        raise RuntimeError(f"{name} diverged on the benchmark log: {failure}")
    return (time.process_time() - t0) / epochs, epochs


def _log(world_name: str, loops: int | None, seed: int) -> tuple[Any, Any, int]:
    """``(world, log, epoch_steps)`` of run 0 of ``world_name`` (``webmap`` or ``drone``;
    ``epoch_steps`` 0 for the drone, whose epochs are its sensor epochs)."""
    from slam.kinds.drone.simulate import simulate_drone
    from slam.kinds.planar.simulate import simulate_planar
    from slam.registry import load_world

    world = load_world(world_name)
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    if world_name == "drone":
        return world, simulate_drone(world, rng), 0
    if loops is not None:
        world = replace(world, vehicle=replace(world.vehicle, loops=loops))
    return world, simulate_planar(world, rng), world.sensor.period_steps


def invariant_cost(variants: tuple[str, ...] = PAIRS, reps: int = 3, loops: int | None = None,
                   seed: int = 0, mode: str = "joint", world_name: str = "webmap"
                   ) -> dict[str, Any]:
    """Per-epoch CPU time of each variant and its twin (both in ``mode``), alternating,
    ``reps`` times, on run 0 of ``world_name`` (``webmap`` or ``drone``)."""
    from estimators.threads import single_thread_blas
    from slam.kinds.planar.variants import split_variant

    world, log, steps = _log(world_name, loops, seed)
    load_before = os.getloadavg()
    epochs = 0
    times: dict[str, dict[str, list[float]]] = {v: {"twin": [], "variant": []}
                                                for v in variants}
    with single_thread_blas():
        for rep in range(reps):
            for v in variants:
                order = (("twin", split_variant(v)[0]), ("variant", v))
                for role, name in order if rep % 2 == 0 else order[::-1]:
                    cpu, epochs = _cpu_per_epoch(log, name, steps, mode)
                    times[v][role].append(cpu)
    rows = {}
    for v in variants:
        t = times[v]
        ratios = [a / b for a, b in zip(t["variant"], t["twin"])]
        rows[v] = {"twin": split_variant(v)[0], "cpu_s_per_epoch_twin": t["twin"],
                   "cpu_s_per_epoch_variant": t["variant"], "ratios": ratios,
                   "ratio_median": statistics.median(ratios), "ratio_min": min(ratios),
                   "ratio_of_min_times": min(t["variant"]) / min(t["twin"]),
                   "meets_target": statistics.median(ratios) <= TARGET}
    return {"note": f"CPU seconds per epoch (whole run incl. recording), one {world_name} log, "
                    "BLAS on one thread, twin and variant alternating; shared machine: "
                    "compare ratios only",
            "world": world_name, "loops": getattr(world.vehicle, "loops", None), "seed": seed,
            "reps": reps,
            "mode": mode,
            "epochs": epochs, "target_ratio": TARGET,
            "load_average_before": load_before, "load_average_after": os.getloadavg(),
            "filters": rows}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--loops", type=int, default=None, help="webmap loops (default: the world's)")
    ap.add_argument("--pairs", default=",".join(PAIRS), help="comma-separated variants")
    ap.add_argument("--mode", choices=("joint", "local"), default="joint")
    ap.add_argument("--world", choices=("webmap", "drone"), default="webmap")
    a = ap.parse_args(argv)
    print(json.dumps(invariant_cost(tuple(a.pairs.split(",")), a.reps, a.loops, mode=a.mode,
                                    world_name=a.world), indent=1))


if __name__ == "__main__":
    main()
