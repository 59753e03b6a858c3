"""Spot check of a recorded log's online row (``slam run --log FILE --online``): at a few
filter epochs, iSAM2's pose there against the Levenberg-Marquardt optimum of the records
up to that pose (the smoother of the log's prefix), and against the final smoother.

    python -m benchmarks.online_check [--log FILE] [--at 0.25,0.5,0.75]
    python -m benchmarks.online_check --cpu ekf-inv,iekf-inv [--mode joint]

Default log: GTSAM's ``victoria_park.txt``.  Prints JSON: per checked epoch the distance
(m) and heading difference (rad) of the row to the prefix's optimum and its distance to
the final smoother's pose there (:math:`x_{k|k}` against :math:`x_{k|N}`).  With ``--cpu``
instead: the CPU time (``time.process_time``, BLAS on one thread, one after the other in
this process) per filter epoch of each filter and of the online pass (iSAM2 pose by pose
with the row's reads, plus the smoother's final LM polish), and each filter's over the
online pass's.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from estimators import wrap_angle


def check(path: Path, fractions: list[float]) -> dict[str, Any]:
    """The spot check of the log at ``path`` at the epochs ``fractions`` of the way."""
    from slam.kinds.recorded.log import read_odometry_log
    from slam.kinds.recorded.models import recorded_epochs
    from slam.kinds.recorded.online import online_recorded
    from slam.kinds.recorded.reference import smooth_recorded

    log = read_odometry_log(path)
    steps = recorded_epochs(log)
    row, ref = online_recorded(log, steps)
    out = []
    for f in fractions:
        e = int(round(f * (len(steps) - 1)))
        k = int(steps[e])
        sub = smooth_recorded(log.prefix(k + 1))
        d = sub.poses[-1] - row.poses[e]
        out.append({"epoch": e, "pose": k,
                    "to_prefix_optimum_m": float(np.hypot(d[0], d[1])),
                    "to_prefix_optimum_heading_rad": float(abs(wrap_angle(d[2]))),
                    "to_final_smoother_m": float(np.hypot(*(ref.poses[k, :2]
                                                            - row.poses[e, :2])))})
    return {"log": path.name, "epochs": len(steps), "checked": out}


def cpu(path: Path, filters: list[str], mode: str) -> dict[str, Any]:
    """CPU ms per filter epoch of ``filters`` (in ``mode``) and of the online pass."""
    import time

    from estimators.threads import single_thread_blas
    from slam.kinds.recorded.log import read_odometry_log
    from slam.kinds.recorded.models import recorded_epochs, run_recorded
    from slam.kinds.recorded.online import online_recorded
    from slam.kinds.recorded.world import open_log

    log = read_odometry_log(path)
    settings = open_log(path, filters, mode).filters
    steps = recorded_epochs(log)
    per = 1e3 / (len(steps) - 1)
    out: dict[str, float] = {}
    with single_thread_blas():
        t = time.process_time()
        online_recorded(log, steps)
        out["isam2"] = (time.process_time() - t) * per
        for name in filters:
            t = time.process_time()
            run_recorded(log, name, mode=mode, filter_params=settings.settings_of(name))
            out[name] = (time.process_time() - t) * per
    return {"log": path.name, "mode": mode, "epochs": len(steps), "cpu_ms_per_epoch": out,
            "over_isam2": {n: out[n] / out["isam2"] for n in filters}}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", type=Path, default=None)
    ap.add_argument("--at", default="0.25,0.5,0.75",
                    help="comma-separated fractions of the filter epochs, in [0, 1]")
    ap.add_argument("--cpu", metavar="FILTERS",
                    help="comma-separated filters: measure CPU per epoch instead")
    ap.add_argument("--mode", choices=("joint", "local"), default="joint")
    a = ap.parse_args(argv)
    fractions = [float(x) for x in a.at.split(",") if x.strip()]
    if not fractions or any(not 0.0 <= f <= 1.0 for f in fractions):
        ap.error(f"--at {a.at}: fractions in [0, 1], comma-separated")
    path = a.log
    if path is None:
        import gtsam

        path = Path(gtsam.findExampleDataFile("victoria_park.txt"))
    if a.cpu:
        print(json.dumps(cpu(path, [f for f in a.cpu.split(",") if f], a.mode), indent=1))
        return
    print(json.dumps(check(path, fractions), indent=1))


if __name__ == "__main__":
    main()
