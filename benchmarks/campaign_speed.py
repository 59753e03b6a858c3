"""``python -m benchmarks.campaign_speed``: the batched and the per-run path on the same
campaign, in one process, one maths thread, CPU seconds and their ratio (JSON on stdout).

For each world the two executors run the same campaign (same runs, seed and filters;
``workers=1``), alternating ``--reps`` times; the figures are CPU seconds of this process
(``time.process_time``), so another job on the machine changes them less than wall time
does, and the ratio comes from runs made back to back.  The two summaries are also compared
(every key but timings to 1e-9 relative, the paired differences of near-equal filters to 1e-9
of their MSE: ``tests.golden.regenerate.batched_differences``; the number of differing keys is
reported).

``--old-per-run``: the per-run executor with the dense sigma-point steps
(:func:`estimators.structured.dense_steps`), i.e. the per-run path before the structured
steps, against the batched executor with them (the summaries then agree to round-off, not
bit for bit).  ``--old-smoother``: the per-run path's planar GTSAM reference on its epoch
path (an iSAM2 update after every epoch, as the campaigns ran it before the chunked
schedule; the same optimum: the smoother's rows then agree to about 1e-6 relative, the
stopping point of its Levenberg-Marquardt polish, and are reported among the differing keys).

Defaults (the issue's campaigns): ``bailey`` 50 runs (its 4 filters + smoother), ``webmap``
100 runs (ekf, srckf, srckf-inv), ``drone`` 25 runs, ``star-sensor`` 50 runs.  Worlds or run
counts can be narrowed, e.g. ``--worlds bailey --runs 20``.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass

from estimators.threads import single_thread_blas


@dataclass(frozen=True)
class Case:
    world: str
    runs: int
    filters: tuple[str, ...] | None = None


CASES = {
    "bailey": Case("bailey", 50),
    "webmap": Case("webmap", 100, ("ekf", "srckf", "srckf-inv")),
    "drone": Case("drone", 25),
    "star-sensor": Case("star-sensor", 50),
}


@contextmanager
def epoch_smoother() -> Iterator[None]:
    """The planar GTSAM reference on its epoch path (iSAM2 updated after every epoch,
    ``chunk = 1``: the reference as the campaigns ran it before the chunked schedule) inside
    the block; the same optimum (:mod:`slam.kinds.planar.reference`)."""
    from slam.kinds.planar.reference import smooth_planar

    kw = smooth_planar.__kwdefaults__
    before = kw["chunk"]
    kw["chunk"] = 1
    try:
        yield
    finally:
        kw["chunk"] = before


def _campaign(case: Case, runs: int, executor: str, dense: bool = False,
              old_smoother: bool = False) -> tuple[float, dict]:
    from estimators.structured import dense_steps
    from slam.campaign import run_campaign
    from slam.registry import load_world

    world = load_world(case.world)
    with (dense_steps() if dense else nullcontext()), (
            epoch_smoother() if old_smoother else nullcontext()):
        t0 = time.process_time()
        result = run_campaign(world, runs=runs, filters=case.filters, workers=1,
                              executor=executor)
        return time.process_time() - t0, result.summary


def measure(case: Case, runs: int, reps: int, old_per_run: bool = False,
            old_smoother: bool = False) -> dict:
    """Both paths ``reps`` times, alternating; CPU seconds, ratios and the summary check."""
    from tests.golden.regenerate import batched_differences, strip_timings

    times: dict[str, list[float]] = {"per-run": [], "batched": []}
    summaries = {}
    for rep in range(reps):
        order = ("per-run", "batched") if rep % 2 == 0 else ("batched", "per-run")
        for ex in order:
            old = ex == "per-run"
            seconds, summary = _campaign(case, runs, ex, old_per_run and old,
                                         old_smoother and old)
            times[ex].append(seconds)
            summaries[ex] = strip_timings(summary)
    diff = batched_differences(summaries["per-run"], summaries["batched"])
    ratios = [a / b for a, b in zip(times["per-run"], times["batched"])]
    return {"world": case.world, "runs": runs, "filters": case.filters,
            "per_run_steps": "dense" if old_per_run else "structured",
            "per_run_smoother": "epoch path" if old_smoother else "chunked",
            "cpu_s": times, "ratio_per_run_over_batched": ratios,
            "summary_differences": len(diff), "first_differences": diff[:5]}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.campaign_speed", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--worlds", default=",".join(CASES), help="comma-separated cases")
    p.add_argument("--runs", type=int, help="runs of every case (default: the case's)")
    p.add_argument("--reps", type=int, default=1, help="alternating repetitions")
    p.add_argument("--old-per-run", action="store_true",
                   help="the per-run executor with the dense sigma-point steps")
    p.add_argument("--old-smoother", action="store_true",
                   help="the per-run executor with the planar smoother's epoch path")
    args = p.parse_args(argv)
    out = {"python": platform.python_version(), "machine": platform.machine(), "cases": []}
    with single_thread_blas():
        for name in args.worlds.split(","):
            case = CASES[name]
            out["cases"].append(measure(case, args.runs or case.runs, args.reps,
                                        args.old_per_run, args.old_smoother))
            print(json.dumps(out["cases"][-1]), file=sys.stderr)
    json.dump(out, sys.stdout, indent=2)
    print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
