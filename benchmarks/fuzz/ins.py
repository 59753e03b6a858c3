"""``python -m benchmarks.fuzz.ins``: the fuzz harness's log families applied to the IMU +
GNSS readers (:mod:`benchmarks.fuzz.insmutate`): every case through ``slam run --log``
in a child process with the harness's limits and classifier.  Prints one JSON object:
the unmutated bases' classes, counts per class and family, and every case that was
neither ``ok`` nor ``rejected``.  Example (one job on a shared machine)::

    python -m benchmarks.fuzz.ins --cases 120 --seed 0 --jobs 1 --timeout 120 \\
        > /tmp/fuzz-ins.json
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from .core import Case
from .harness import GOOD, Limits, default_slam, run_case
from .insmutate import CSV, KDIR, csv_base, ins_cases, kitti_base


def _base_case(name: str) -> Case:
    files = csv_base() if name == "csv" else kitti_base()
    extra = tuple((p, str(v).encode("utf-8")) for p, v in files.items())
    return Case("log", "base", name, name, None, extra, target=CSV if name == "csv" else KDIR,
                world_kind="ins-log")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--families", default=None, help="comma-separated family names")
    args = ap.parse_args(argv)
    slam = default_slam()
    limits = Limits(seconds=args.timeout)
    work = Path(tempfile.mkdtemp(prefix="slam-fuzz-ins-"))
    t0 = time.perf_counter()
    try:
        bases = {n: run_case(_base_case(n), work, slam, limits).klass for n in ("csv", "kitti")}
        cases = ins_cases(args.cases, args.seed,
                          args.families.split(",") if args.families else None)
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            outcomes = list(pool.map(lambda c: run_case(c, work, slam, limits), cases))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    report = {
        "config": {"cases": args.cases, "seed": args.seed, "timeout_s": args.timeout},
        "baselines": bases,
        "classes": dict(Counter(o.klass for o in outcomes)),
        "families": {f: dict(Counter(o.klass for o in outcomes if o.case.family == f))
                     for f in sorted({o.case.family for o in outcomes})},
        "wall_s": round(time.perf_counter() - t0, 1),
        "failures": [{**o.record(), "stderr": o.stderr_tail[-2000:]}
                     for o in outcomes if o.klass not in GOOD],
    }
    json.dump(report, sys.stdout, indent=1, ensure_ascii=False)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
