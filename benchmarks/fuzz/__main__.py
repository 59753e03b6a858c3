"""``python -m benchmarks.fuzz``: a whole fuzz campaign against the ``slam`` CLI.

Prints one JSON object on stdout: counts per outcome class, per kind (world/log), per
world kind (alignment, ship, ..., recorded-log), per mutator family and per base world;
the flags per family (``warning-printed``, ``unexplained-null``, ``near-limit`` ...); the
unexplained nulls by path; the ``--out`` safety probe, the wall time and every case that
was neither ``ok`` nor ``rejected``. With ``--keep DIR`` each such case's input (and side
files), stderr tail and record are written to ``DIR/<case id>/``; ``--jsonl FILE`` streams
each record as it finishes; ``--recheck-hangs S`` re-runs each hang alone with a longer
limit (slow under load, or stuck?); ``--families a,b`` runs only those families (world
and log). Progress goes to stderr. The unmutated bases run first (``baselines``): a base
that is not ``ok`` taints its mutations. Example::

    python -m benchmarks.fuzz --worlds 500 --logs 100 --seed 0 --jobs 2 --keep /tmp/fails

The reliability re-run (issue 24: every class of the outside check; one job on a shared
machine, 60 s and 4 GiB per case; expect 0 of every class but ok/rejected)::

    python -m benchmarks.fuzz --worlds 300 --logs 60 --seed 0 --jobs 1 --timeout 60 \
        --mem-gib 4 --recheck-hangs 300 --keep /tmp/fuzz-fails --jsonl /tmp/fuzz.jsonl \
        > /tmp/fuzz.json

and the issue's families alone, more cases each::

    python -m benchmarks.fuzz --worlds 130 --logs 20 --seed 1 --jobs 1 --timeout 60 \
        --mem-gib 4 --families underflow-sigma,kind-size,degenerate-path,paper-types,\
    long-dotted-key,log-huge-int --keep /tmp/fuzz-fails-new > /tmp/fuzz-new.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import signal
import sys
import tempfile
import time
from collections import Counter, defaultdict
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

from .core import LOG_KIND, Base, Case
from .harness import (
    GOOD,
    Limits,
    Outcome,
    Usage,
    default_slam,
    kill_all,
    out_probe,
    run_case,
    write_case,
)
from .mutate import (
    LOG_FAMILIES,
    WORLD_FAMILIES,
    load_bases,
    load_log_lines,
    log_cases,
    render,
    world_cases,
)
from .verdicts import null_pattern

ROOT = Path(__file__).resolve().parents[2]


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command-line options."""
    p = argparse.ArgumentParser(prog="python -m benchmarks.fuzz", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--worlds", type=int, default=500, help="generated world cases")
    p.add_argument("--logs", type=int, default=100, help="generated log cases")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--jobs", type=int, default=2, help="cases run at once")
    p.add_argument("--keep", type=Path, help="folder for the failing cases")
    p.add_argument("--timeout", type=float, default=60.0, help="wall seconds per case")
    p.add_argument("--mem-gib", type=float, default=4.0, help="address space per case")
    p.add_argument("--reject-cpu", type=float, default=5.0,
                   help="CPU seconds above which a rejection is a costly-rejection")
    p.add_argument("--reject-mib", type=float, default=1024.0,
                   help="peak MiB above which a rejection is a costly-rejection")
    p.add_argument("--families", help="comma-separated families to run (default: all)")
    p.add_argument("--slam", help="the slam command (default: `slam` next to python)")
    p.add_argument("--worlds-dir", type=Path, default=ROOT / "worlds")
    p.add_argument("--bases", help="comma-separated world names to mutate (default: all)")
    p.add_argument("--log-file", type=Path, help="log to mutate (default: victoria_park)")
    p.add_argument("--log-lines", type=int, default=300, help="truncate the log to this")
    p.add_argument("--workdir", type=Path, help="scratch folder (default: a new temp dir)")
    p.add_argument("--no-probe", action="store_true", help="skip the --out safety probe")
    p.add_argument("--jsonl", type=Path, help="also append each case's record to this file")
    p.add_argument("--recheck-hangs", type=float, metavar="SECONDS",
                   help="re-run each hang alone with this longer limit, to tell slow from stuck")
    p.add_argument("--resume", action="store_true",
                   help="with --jsonl: keep the cases already recorded there (same seed and "
                        "bases) and run the rest; one stopped from outside (SIGTERM) runs again")
    return p.parse_args(argv)


def tally(outcomes: list[Outcome]) -> dict[str, Any]:
    """Counts per class, and per class within kind, world kind, family and base; flags per
    family and world kind; unexplained nulls by path pattern (cases holding each)."""
    def by(attr: str, flags: bool = False) -> dict[str, dict[str, int]]:
        """Class (or flag) counts grouped by a case attribute."""
        groups: dict[str, Counter[str]] = defaultdict(Counter)
        for o in outcomes:
            groups[getattr(o.case, attr)].update(o.flags if flags else [o.klass])
        return {k: dict(sorted(v.items())) for k, v in sorted(groups.items()) if v}

    nulls: Counter[str] = Counter()
    for o in outcomes:
        nulls.update({null_pattern(p) for p in o.nulls})
    return {"cases": len(outcomes), "counts": dict(Counter(o.klass for o in outcomes)),
            "flags": dict(Counter(f for o in outcomes for f in o.flags)),
            "by_kind": by("kind"), "by_world_kind": by("world_kind"),
            "by_family": by("family"), "by_base": by("base"),
            "flags_by_family": by("family", True), "flags_by_world_kind": by("world_kind", True),
            "unexplained_null_paths": dict(nulls.most_common())}


def keep_case(outcome: Outcome, keep: Path) -> None:
    """Write a failing case's input, side files, stderr tail and record under ``keep``."""
    folder = keep / outcome.case.ident
    write_case(outcome.case, folder)
    (folder / "stderr-tail.txt").write_text(outcome.stderr_tail + "\n", encoding="utf-8")
    (folder / "record.json").write_text(json.dumps(outcome.record(), indent=1) + "\n",
                                        encoding="utf-8")


def run_all(cases: list[Case], workdir: Path, slam: list[str], limits: Limits, jobs: int,
            stream: TextIO | None = None, indices: list[int] | None = None) -> list[Outcome]:
    """Run every case, ``jobs`` at a time, reporting progress on stderr (and each record
    as a JSON line on ``stream``, with its index in ``indices``, default its position);
    -> outcomes in input order."""
    done: dict[int, Outcome] = {}
    pool = ThreadPoolExecutor(max_workers=max(1, jobs))
    index = list(range(len(cases))) if indices is None else indices
    try:
        futures = {pool.submit(run_case, c, workdir, slam, limits,
                               folder_name=f"{index[i]:04d}-{c.ident}"): i
                   for i, c in enumerate(cases)}
        for fut in as_completed(futures):
            o = fut.result()
            done[futures[fut]] = o
            print(f"[{len(done)}/{len(cases)}] {o.klass:<18} {o.seconds:6.1f}s "
                  f"{o.case.family}/{o.case.base}: {o.case.name[:70]}", file=sys.stderr)
            if stream is not None:
                stream.write(json.dumps({"index": index[futures[fut]], **o.record()},
                                        ensure_ascii=False) + "\n")
                stream.flush()
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        kill_all()
        raise
    pool.shutdown()
    return [done[i] for i in range(len(cases))]


def resumed(jsonl: Path, cases: list[Case]) -> dict[int, Outcome]:
    """The outcomes already recorded in ``jsonl`` for these ``cases`` (by index), leaving
    out a case stopped from outside (SIGTERM: the harness itself stops cases with SIGKILL)."""
    kept: dict[int, Outcome] = {}
    if not jsonl.exists():
        return kept
    for line in jsonl.read_text(encoding="utf-8").splitlines():
        r = json.loads(line)
        i = r.get("index")
        if not isinstance(i, int) or not 0 <= i < len(cases) or r.get("rc") in (143, -15):
            continue
        if r["id"] != cases[i].ident:
            raise SystemExit(f"--resume: {jsonl} holds another campaign (case {i})")
        kept[i] = Outcome(cases[i], r["class"], r["rc"], r["seconds"], r["detail"],
                          usage=Usage(r.get("cpu_s", 0.0), r.get("peak_mib", 0.0)),
                          flags=tuple(r.get("flags", ())), nulls=tuple(r.get("nulls", ())))
    return kept


def baselines(bases: list[Base], lines: list[str], workdir: Path, slam: list[str],
              limits: Limits, jobs: int) -> dict[str, str]:
    """Each unmutated (cheapened) base and the truncated log, without and with figures
    (``<name> (figures)``; the other cases run without, but ``paper-types``): their class
    should be ok; if one is not, every mutation of it is suspect."""
    cases = [render(b, "baseline", "unmodified") for b in bases]
    cases.append(Case("log", "baseline", "unmodified", "victoria",
                      ("\n".join(lines) + "\n").encode(), world_kind=LOG_KIND))
    cases += [replace(c, name="unmodified, with figures", plots=True) for c in list(cases)]
    return {f"{o.case.base}{' (figures)' if o.case.plots else ''}":
            o.klass if o.klass == "ok" else f"{o.klass}: {o.detail}"
            for o in run_all(cases, workdir, slam, limits, jobs)}


def probe(slam: list[str], workdir: Path, bases: list[Any], lines: list[str],
          limits: Limits) -> dict[str, Any]:
    """The ``--out`` safety probe on a cheap good world, a rejected one and a good log."""
    import copy

    base = next((b for b in bases if b.name == "bailey"), bases[0])
    good = render(base, "probe", "unmodified")
    doc = copy.deepcopy(base.doc)
    doc.setdefault("filters", {})["names"] = ["nope"]
    bad = render(base, "probe", "unknown filter", doc)
    log = Case("log", "probe", "unmodified", "victoria", ("\n".join(lines) + "\n").encode())
    return out_probe(slam, workdir, good, bad, log, limits)


def recheck(outcomes: list[Outcome], workdir: Path, slam: list[str], limits: Limits,
            seconds: float) -> list[dict[str, Any]]:
    """Re-run every ``hang`` one at a time with a ``seconds`` limit; the primary class is
    kept, the recheck's class and time are reported next to it."""
    longer = replace(limits, seconds=seconds)
    hangs = [o for o in outcomes if o.klass == "hang"]
    again = run_all([o.case for o in hangs], workdir, slam, longer, 1)
    return [{"id": o.case.ident, "mutation": o.case.name, "class": a.klass,
             "seconds": round(a.seconds, 1), "cpu_s": round(a.usage.cpu_s, 1),
             "peak_mib": round(a.usage.peak_mib), "detail": a.detail}
            for o, a in zip(hangs, again)]


def chosen_families(given: str | None) -> tuple[list[str] | None, list[str] | None]:
    """``--families``: (world families, log families); ``None`` = all of that side, ``[]``
    = none (only families of the other side were named)."""
    if given is None:
        return None, None
    names = [n for n in given.split(",") if n]
    unknown = [n for n in names if n not in WORLD_FAMILIES and n not in LOG_FAMILIES]
    if unknown:
        known = ", ".join([*WORLD_FAMILIES, *LOG_FAMILIES])
        raise SystemExit(f"--families: unknown {unknown}; known: {known}")
    return ([n for n in names if n in WORLD_FAMILIES], [n for n in names if n in LOG_FAMILIES])


def main(argv: list[str] | None = None) -> int:
    """Run the campaign; print the JSON report."""
    args = parse_args(argv)
    slam = shlex.split(args.slam) if args.slam else default_slam()
    limits = Limits(seconds=args.timeout, memory_bytes=int(args.mem_gib * (1 << 30)),
                    reject_cpu_s=args.reject_cpu, reject_mib=args.reject_mib)
    bases = load_bases(args.worlds_dir)
    if args.bases:
        wanted = args.bases.split(",")
        bases = [b for b in bases if b.name in wanted]
        if len(bases) != len(wanted):
            raise SystemExit(f"--bases: not all of {wanted} are in {args.worlds_dir}")
    lines = load_log_lines(args.log_file, args.log_lines)
    worlds, logs = chosen_families(args.families)
    cases = ((world_cases(args.worlds, args.seed, bases, worlds) if worlds != [] else [])
             + (log_cases(args.logs, args.seed, lines, logs) if logs != [] else []))
    own = args.workdir is None
    workdir = Path(tempfile.mkdtemp(prefix="slam-fuzz-")) if own else args.workdir
    workdir.mkdir(parents=True, exist_ok=True)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # so run_all kills the cases
    t0 = time.perf_counter()
    base_classes = baselines(bases, lines, workdir, slam, limits, args.jobs)
    kept = resumed(args.jsonl, cases) if args.resume and args.jsonl else {}
    todo = [i for i in range(len(cases)) if i not in kept]
    if args.jsonl:
        with open(args.jsonl, "a", encoding="utf-8") as stream:
            ran = run_all([cases[i] for i in todo], workdir, slam, limits, args.jobs, stream,
                          todo)
    else:
        ran = run_all(cases, workdir, slam, limits, args.jobs)
    outcomes = [kept[i] if i in kept else ran[todo.index(i)] for i in range(len(cases))]
    cases_wall = round(time.perf_counter() - t0, 1)
    report: dict[str, Any] = {
        "config": {"worlds": args.worlds, "logs": args.logs, "seed": args.seed,
                   "jobs": args.jobs, "timeout_s": args.timeout, "mem_gib": args.mem_gib,
                   "reject_cpu_s": args.reject_cpu, "reject_mib": args.reject_mib,
                   "families": {"world": worlds or list(WORLD_FAMILIES),
                                "log": logs or list(LOG_FAMILIES)}
                   if args.families is None else {"world": worlds, "log": logs},
                   "slam": slam, "log_lines": args.log_lines,
                   "bases": [b.name for b in bases]},
        "baselines": base_classes,
        **tally(outcomes),
    }
    if args.recheck_hangs:
        report["hang_recheck"] = recheck(outcomes, workdir, slam, limits, args.recheck_hangs)
    if not args.no_probe:
        report["out_probe"] = probe(slam, workdir, bases, lines, limits)
    report["cases_wall_s"] = cases_wall  # baselines + all cases
    report["wall_s"] = round(time.perf_counter() - t0, 1)  # and the recheck and probe
    failures = [o for o in outcomes if o.klass not in GOOD]
    report["failures"] = [o.record() for o in failures]
    # a base that does not run unmodified makes its mutations meaningless: a failure too
    report["bases_not_ok"] = {b: c for b, c in base_classes.items() if c != "ok"}
    if args.keep:
        for o in failures:
            keep_case(o, args.keep)
    if own:
        shutil.rmtree(workdir, ignore_errors=True)
    json.dump(report, sys.stdout, indent=1, ensure_ascii=False)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
