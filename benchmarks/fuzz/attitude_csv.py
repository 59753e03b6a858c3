"""Seeded mutators for recorded attitude logs in GTSAM's ``EqFdata.csv`` layout, and a
campaign runner: ``python -m benchmarks.fuzz.attitude_csv --cases 60 --jobs 1``.

The harness's families applied to the CSV reader (:mod:`slam.kinds.attitude_log.log`):
numbers (non-finite, huge, garbage, empty fields), noise (σ ≤ 0, varying, huge),
geometry (non-unit quaternions and directions, zero readings, partial NaN triples),
structure (columns dropped, duplicated, renamed; rows dropped, repeated, reordered,
truncated), binary junk, huge inputs (many rows or columns, huge sensor numbers) and
paths.  Each family is ``f(rng, lines) -> (name, bytes | path)`` over the first rows of
the wheel's file; :func:`csv_cases` wraps them in :class:`~benchmarks.fuzz.core.Case`
records (``kind="log"``: the harness runs them with ``slam run --log``, which recognises
the layout by its header).  The runner prints the harness's tally as JSON.
"""

from __future__ import annotations

import argparse
import json
import random
import shlex
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from .core import Case, binary_variant, registrar, seeded_families

KIND = "recorded-attitude"
Result = tuple[str, bytes | str]
CsvFamily = Callable[[random.Random, list[str]], Result]
CSV_FAMILIES: dict[str, CsvFamily] = {}
"""The families, by name, in definition order."""
mutator = registrar(CSV_FAMILIES)


def load_csv_lines(n: int = 60) -> list[str]:
    """The header and the first ``n`` rows of GTSAM's ``EqFdata.csv``."""
    import gtsam

    text = Path(gtsam.findExampleDataFile("EqFdata.csv")).read_text(encoding="utf-8")
    return text.splitlines()[:n + 1]


def _join(lines: list[str]) -> bytes:
    return ("\n".join(lines) + "\n").encode("utf-8")


def _cols(lines: list[str]) -> list[str]:
    return lines[0].split(",")


def _set(lines: list[str], i: int, j: int, tok: str) -> None:
    t = lines[i].split(",")
    t[j] = tok
    lines[i] = ",".join(t)


def _column(rng: random.Random, lines: list[str], prefix: str = "") -> int:
    cols = [j for j, c in enumerate(_cols(lines)) if c.startswith(prefix)]
    return rng.choice(cols)


_NUMBERS = ("nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e400", "", " ", "abc", "0x10",
            "1,5", "--1", "1e-400", "9" * 5000, "0." + "0" * 4000 + "1")


@mutator("csv-number")
def fam_number(rng: random.Random, lines: list[str]) -> Result:
    """One field (or a whole column) replaced by a non-finite, huge, tiny or non-number."""
    out = list(lines)
    j, tok = _column(rng, out), rng.choice(_NUMBERS)
    rows = range(1, len(out)) if rng.random() < 0.3 else [rng.randrange(1, len(out))]
    for i in rows:
        _set(out, i, j, tok)
    where = "every row" if len(rows) > 1 else f"line {rows[0] + 1}"
    return f"{where}: {_cols(out)[j]} = {tok[:20]!r}", _join(out)


@mutator("csv-noise")
def fam_noise(rng: random.Random, lines: list[str]) -> Result:
    """Gyro or sensor σ zero, negative, huge, tiny or varying between rows."""
    out = list(lines)
    j = _column(rng, out, "std_")
    tok = rng.choice(["0", "-1e-4", "1e6", "1e-300", "5e-324", "2"])
    if rng.random() < 0.5:
        for i in range(1, len(out)):
            _set(out, i, j, tok)
        return f"every row: {_cols(out)[j]} = {tok}", _join(out)
    i = rng.randrange(2, len(out))
    _set(out, i, j, tok)
    return f"line {i + 1}: {_cols(out)[j]} = {tok} (varies)", _join(out)


@mutator("csv-geometry")
def fam_geometry(rng: random.Random, lines: list[str]) -> Result:
    """Quaternions and directions not of unit length, zero readings, partial triples."""
    out = list(lines)
    cols = _cols(out)
    i = rng.randrange(1, len(out))
    choice = rng.randrange(5)
    if choice == 0:
        prefix = rng.choice(["q_", "cq_"])
        for j, c in enumerate(cols):
            if c.startswith(prefix):
                _set(out, i, j, rng.choice(["0", "2", "1e-9"]))
        return f"line {i + 1}: {prefix}* scaled off the unit sphere", _join(out)
    prefix = rng.choice(["y_", "d_"])
    sensor = rng.choice(["0", "1"])
    js = [j for j, c in enumerate(cols) if c.startswith(prefix) and c.endswith("_" + sensor)
          and not c.startswith("std")]
    if choice == 1:
        for j in js:
            _set(out, i, j, "0")
        return f"line {i + 1}: {prefix}*_{sensor} all zero", _join(out)
    if choice == 2:
        _set(out, i, rng.choice(js), "NaN")
        return f"line {i + 1}: one of {prefix}*_{sensor} NaN", _join(out)
    if choice == 3:
        for j in js:
            _set(out, i, j, "1e200")
        return f"line {i + 1}: {prefix}*_{sensor} = 1e200", _join(out)
    for row in range(1, len(out)):
        for j in js:
            _set(out, row, j, "NaN")
    return f"every row: {prefix}*_{sensor} NaN (a sensor that never reads)", _join(out)


@mutator("csv-structure")
def fam_structure(rng: random.Random, lines: list[str]) -> Result:
    """Header and rows: columns dropped, duplicated, renamed; rows dropped, repeated,
    reversed; the file truncated mid-line, empty, header only."""
    out = list(lines)
    cols = _cols(out)
    text = "\n".join(out) + "\n"
    cut = rng.randrange(1, len(text))
    j = rng.randrange(len(cols))
    options: list[tuple[str, Callable[[], list[str] | str]]] = [
        (f"header column {cols[j]} dropped", lambda: [",".join(cols[:j] + cols[j + 1:])]
         + out[1:]),
        (f"column {cols[j]} dropped", lambda: [",".join(r.split(",")[:j] + r.split(",")[j + 1:])
                                               for r in out]),
        (f"column {cols[j]} renamed", lambda: [",".join(cols[:j] + [cols[j] + "X"]
                                                        + cols[j + 1:])] + out[1:]),
        (f"header names {cols[j]} twice", lambda: [",".join(cols[:j] + [cols[j]] + cols[j:])]
         + out[1:]),
        ("rows reversed", lambda: [out[0], *reversed(out[1:])]),
        ("a row repeated", lambda: out[:5] + [out[4]] + out[5:]),
        ("header only", lambda: out[:1]),
        ("empty file", lambda: ""),
        ("no header", lambda: out[1:]),
        ("truncated mid-line", lambda: text[:cut]),
        ("a row with an extra field", lambda: out[:3] + [out[3] + ",1"] + out[4:]),
        ("semicolons for commas", lambda: [r.replace(",", ";") for r in out]),
        ("CRLF line ends", lambda: "\r\n".join(out) + "\r\n"),
        ("sensor 7 columns added", lambda: [out[0] + ",y_x_7,y_y_7,y_z_7"]
         + [r + ",NaN,NaN,NaN" for r in out[1:]]),
    ]
    name, make = rng.choice(options)
    got = make()
    return name, (got.encode("utf-8") if isinstance(got, str) else _join(got))


@mutator("csv-binary")
def fam_binary(rng: random.Random, lines: list[str]) -> Result:
    """Binary junk, NUL bytes, invalid UTF-8, UTF-16, a BOM."""
    return binary_variant(rng, _join(lines))


@mutator("csv-huge")
def fam_huge(rng: random.Random, lines: list[str]) -> Result:
    """Long logs, huge time stamps and gaps, thousands of columns."""
    out = list(lines)
    choice = rng.randrange(4)
    if choice == 0:
        n = rng.choice([20_000, 200_000])
        body = out[1:]
        rows = []
        for k in range(n):
            t = body[k % len(body)].split(",")
            t[0] = repr(k * 0.005)
            rows.append(",".join(t))
        return f"{n} rows", _join([out[0], *rows])
    if choice == 1:
        for i in range(1, len(out)):
            _set(out, i, 0, repr(1e300 * i))
        return "t = 1e300 * row", _join(out)
    if choice == 2:
        i = rng.randrange(2, len(out))
        for k in range(i, len(out)):
            t = out[k].split(",")
            t[0] = repr(float(t[0]) + 1e6)
            out[k] = ",".join(t)
        return f"a gap of 1e6 s before line {i + 1}", _join(out)
    extra = 5000
    return (f"{extra} extra columns", _join([out[0] + "".join(f",x{m}" for m in range(extra))]
                                            + [r + ",0" * extra for r in out[1:]]))


_PATHS = ("/dev/zero", "/dev/null", ".", "missing.csv")


@mutator("csv-path")
def fam_path(rng: random.Random, lines: list[str]) -> Result:
    """``--log`` pointing at /dev/zero, /dev/null, a folder, a missing file."""
    target = rng.choice(_PATHS)
    return f"--log {target}", target


def csv_cases(n: int, seed: int, lines: list[str], families: list[str] | None = None
              ) -> list[Case]:
    """``n`` cases for ``seed``: case ``i`` uses family ``i mod F``."""
    out = []
    for rng, family in seeded_families(n, seed, "csv", families or list(CSV_FAMILIES)):
        name, result = CSV_FAMILIES[family](rng, lines)
        if isinstance(result, str):
            out.append(Case("log", family, name, "eqf", None, target=result, world_kind=KIND))
        else:
            out.append(Case("log", family, name, "eqf", result, world_kind=KIND))
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the CSV cases through ``slam run --log`` (the harness's limits and classes)."""
    from .__main__ import run_all, tally
    from .harness import GOOD, Limits, default_slam

    p = argparse.ArgumentParser(prog="python -m benchmarks.fuzz.attitude_csv")
    p.add_argument("--cases", type=int, default=60)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--rows", type=int, default=60, help="rows of EqFdata.csv mutated")
    p.add_argument("--timeout", type=float, default=60.0)
    p.add_argument("--mem-gib", type=float, default=4.0)
    p.add_argument("--slam", help="the slam command (default: `slam` next to python)")
    args = p.parse_args(argv)
    slam = shlex.split(args.slam) if args.slam else default_slam()
    limits = Limits(seconds=args.timeout, memory_bytes=int(args.mem_gib * (1 << 30)))
    lines = load_csv_lines(args.rows)
    base = Case("log", "baseline", "unmodified", "eqf", _join(lines), world_kind=KIND)
    cases = [base, *csv_cases(args.cases, args.seed, lines)]
    with tempfile.TemporaryDirectory(prefix="slam-fuzz-csv-") as work:
        outcomes = run_all(cases, Path(work), slam, limits, args.jobs)
    report = {"config": vars(args) | {"slam": slam}, "baseline": outcomes[0].klass,
              **tally(outcomes[1:]),
              "failures": [o.record() for o in outcomes[1:] if o.klass not in GOOD]}
    json.dump(report, sys.stdout, indent=1, ensure_ascii=False, default=str)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
