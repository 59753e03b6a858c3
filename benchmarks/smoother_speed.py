"""``python -m benchmarks.smoother_speed``: each kind's GTSAM reference on its epoch path
(iSAM2 updated after every epoch, what the online row needs) against its default path, in
one process, one maths thread: CPU seconds per run, their ratio, and the largest relative
difference of the final objective (½χ²) between the two (JSON on stdout).

The paths alternate run by run on the same simulated logs, so the ratio comes from runs
made back to back (CPU seconds of this process, ``time.process_time``).  One function per
kind (:data:`KINDS`); ``--kinds planar --worlds bailey --runs 3`` narrows it.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections.abc import Callable

import numpy as np

from estimators.threads import single_thread_blas

PLANAR_WORLDS = ("bailey", "webmap", "densemap")


def _cpu(fn: Callable[[], object]) -> tuple[float, object]:
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def planar(worlds: tuple[str, ...] = PLANAR_WORLDS, runs: int = 3) -> list[dict]:
    """The planar smoother (:func:`slam.kinds.planar.reference.smooth_planar`): ``chunk = 1``
    (the epoch path) against the default chunked path, ``runs`` logs per world (seeds
    0..runs-1)."""
    from slam.kinds.planar.reference import DEFAULT_CHUNK, smooth_planar
    from slam.kinds.planar.simulate import simulate_planar
    from slam.registry import load_world

    rows = []
    for name in worlds:
        world = load_world(name)
        old, new, rel = [], [], []
        for seed in range(runs):
            log = simulate_planar(world, np.random.default_rng(seed))
            t_old, r_old = _cpu(lambda log=log: smooth_planar(log, chunk=1))
            t_new, r_new = _cpu(lambda log=log: smooth_planar(log, chunk=DEFAULT_CHUNK))
            old.append(t_old)
            new.append(t_new)
            rel.append(abs(r_new.objective - r_old.objective) / abs(r_old.objective))
        rows.append({"kind": "planar-slam", "world": name, "runs": runs,
                     "path_old": "epoch (chunk 1)", "path_new": f"chunk {DEFAULT_CHUNK}",
                     "cpu_per_run_old_s": float(np.mean(old)),
                     "cpu_per_run_new_s": float(np.mean(new)),
                     "ratio": float(np.sum(old) / np.sum(new)),
                     "objective_max_rel_diff": float(np.max(rel))})
    return rows


KINDS: dict[str, Callable[..., list[dict]]] = {"planar": planar}
"""One benchmark function per kind: ``fn(worlds=..., runs=...) -> rows`` (worlds optional)."""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default=",".join(KINDS), help="comma-separated kinds")
    ap.add_argument("--worlds", default=None, help="comma-separated worlds (planar)")
    ap.add_argument("--runs", type=int, default=3, help="logs per world")
    args = ap.parse_args(argv)
    rows = []
    with single_thread_blas():
        for kind in args.kinds.split(","):
            if kind not in KINDS:
                ap.error(f"--kinds: unknown kind {kind!r}; known: {', '.join(KINDS)}")
            kw = {"runs": args.runs}
            if args.worlds and kind == "planar":
                kw["worlds"] = tuple(args.worlds.split(","))
            rows += KINDS[kind](**kw)
    json.dump({"python": platform.python_version(), "rows": rows}, sys.stdout, indent=2)
    print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
