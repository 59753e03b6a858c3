"""SRCKF (and the other INS filters) against iSAM2 on GTSAM's KITTI log, side by side in
one process: CPU seconds (``time.process_time``) of each estimator's whole run, BLAS on one
thread, alternating ``--repeats`` times; the held-out RMSE (``--holdout``) of each run
shows the estimates are the same with and without the preintegrated prediction, and with
the epochs preintegrated in batches (the log's ``preintegration_fixes``) or each alone.
On a shared machine the fastest of the repeats (``cpu_s_min``, and its ratio) is the steadier
figure: other jobs only ever add time.

    python -m benchmarks.kitti_speed --repeats 3
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--holdout", type=int, default=5)
    ap.add_argument("--filters", default="srckf,ekf")
    args = ap.parse_args(argv)
    from estimators.threads import single_thread_blas

    with single_thread_blas():
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    import nav.ins as ins
    from slam.kinds.ins_log import reference
    from slam.kinds.ins_log.run import alignment, fix_roles, run_filter
    from slam.kinds.ins_log.scoring import score_track
    from slam.kinds.ins_log.world import open_log

    names = args.filters.split(",")
    w = open_log(Path("kitti"), names, None, holdout=args.holdout)
    log = w.log
    roles = fix_roles(log, w.scoring)
    a, x0, P0, _ = alignment(log, roles)
    log.epochs  # noqa: B018 - cut once, outside the timings
    cpu: dict[str, list[float]] = {}
    rmse: dict[str, float] = {}
    default = ins.ins_transition.__kwdefaults__["preintegrated"]
    k = w.log.settings.preintegration_fixes
    per_epoch = replace(w, log=replace(log, settings=replace(log.settings,
                                                             preintegration_fixes=1)))
    per_epoch.log.epochs  # noqa: B018
    variants = ((True, w, ""), (True, per_epoch, " (each epoch preintegrated alone)"),
                (False, w, " (each point mechanised)")) if k > 1 else (
                    (True, w, ""), (False, w, " (each point mechanised)"))
    for _ in range(args.repeats):
        for variant, world, label in variants:
            ins.ins_transition.__kwdefaults__["preintegrated"] = variant
            for n in names:
                tr = run_filter(world, n, a, x0, P0, roles)
                key = f"{n}{label}"
                cpu.setdefault(key, []).append(tr.cpu_s)
                rmse[key] = score_track(log, tr, a, roles, w.scoring)["heldout"]["rmse_m"]
        ins.ins_transition.__kwdefaults__["preintegrated"] = default
        tracks = reference.smooth(log, a, x0, P0, roles)
        for n, tr in tracks.items():
            key = "isam2 online" if n == "gtsam-online" else "isam2 + final smoothing"
            cpu.setdefault(key, []).append(tr.cpu_s)
            rmse[key] = score_track(log, tr, a, roles, w.scoring)["heldout"]["rmse_m"]
    med = {k: float(np.median(v)) for k, v in cpu.items()}
    low = {k: float(np.min(v)) for k, v in cpu.items()}
    base = med["isam2 online"]
    out = {"repeats": args.repeats, "cpu_s_median": med,
           "cpu_over_isam2_online": {k: v / base for k, v in med.items()},
           "cpu_s_min": low,
           "min_over_isam2_online_min": {k: v / low["isam2 online"] for k, v in low.items()},
           "heldout_rmse_m": rmse}
    json.dump(out, sys.stdout, indent=1)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
