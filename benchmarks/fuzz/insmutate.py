"""Seeded mutators for IMU + GNSS logs: the CSV layout with its sidecar TOML and GTSAM's
KITTI files (:mod:`slam.kinds.ins_log`), the families of :mod:`benchmarks.fuzz.logmutate`
(hostile numbers, structure, binary junk, paths) plus time stamps and the sidecar's keys.

The bases are small: the synthetic 20 s constant-turn CSV (:mod:`slam.kinds.ins_log.synthetic`)
and the first 3000 IMU rows of the KITTI drive with the GPS rows inside them.  Each family
is ``f(rng, files) -> (name, files)`` over the base's files (name -> text); a case passes
``--log case.csv`` or ``--log kitti_dir`` (:func:`ins_cases`).  Run a campaign with
``python -m benchmarks.fuzz.ins``.
"""

from __future__ import annotations

import random
import re
from collections.abc import Callable
from pathlib import Path

from .core import Case, binary_variant, registrar, seeded_families
from .logmutate import _TOKENS

INS_KIND = "ins-log"
CSV, SIDE = "case.csv", "case.toml"
KDIR = "kitti_dir"
KITTI_NAMES = ("KittiEquivBiasedImu.txt", "KittiGps_converted.txt",
               "KittiEquivBiasedImu_metadata.txt")

Files = dict[str, str | bytes]
Family = Callable[[random.Random, Files], tuple[str, Files]]
INS_FAMILIES: dict[str, Family] = {}
mutator = registrar(INS_FAMILIES)


def csv_base() -> Files:
    from slam.kinds.ins_log.synthetic import log_text

    csv, side = log_text(duration=20.0)
    return {CSV: csv, SIDE: side}


def kitti_base(rows: int = 3000) -> Files:
    from slam.kinds.ins_log.readers import bundled_kitti

    folder = bundled_kitti()
    imu = (folder / KITTI_NAMES[0]).read_text().splitlines()[: rows + 1]
    t_end = float(imu[-1].split()[0])
    gps = [ln for k, ln in enumerate((folder / KITTI_NAMES[1]).read_text().splitlines())
           if k == 0 or float(ln.split(",")[0]) <= t_end]
    meta = (folder / KITTI_NAMES[2]).read_text()
    return {f"{KDIR}/{KITTI_NAMES[0]}": "\n".join(imu) + "\n",
            f"{KDIR}/{KITTI_NAMES[1]}": "\n".join(gps) + "\n", f"{KDIR}/{KITTI_NAMES[2]}": meta}


def _data_files(files: Files) -> list[str]:
    return [n for n in files if n != SIDE]


def _sep(name: str) -> str | None:
    return "," if name.endswith((".csv", "Gps_converted.txt")) else None


def _split(line: str, sep: str | None) -> list[str]:
    return line.split(sep) if sep else line.split(" ")


def _join(parts: list[str], sep: str | None) -> str:
    return (sep or " ").join(parts)


@mutator("ins-number")
def fam_number(rng: random.Random, files: Files) -> tuple[str, Files]:
    """One field of one data row (or of every row) replaced by a hostile token."""
    out = dict(files)
    name = rng.choice(_data_files(files))
    lines = str(out[name]).splitlines()
    sep = _sep(name)
    tok = rng.choice(_TOKENS)
    j = rng.randrange(len(_split(lines[1], sep)))
    every = rng.random() < 0.2
    rows = range(1, len(lines)) if every else [rng.randrange(1, len(lines))]
    for i in rows:
        parts = _split(lines[i], sep)
        if j < len(parts):
            parts[j] = tok
            lines[i] = _join(parts, sep)
    out[name] = "\n".join(lines) + "\n"
    shown = tok if len(tok) < 20 else f"{tok[:3]}...({len(tok)} chars)"
    where = "every row" if every else f"line {rows[0] + 1}"
    return f"{name} {where} field {j} = {shown!r}", out


@mutator("ins-structure")
def fam_structure(rng: random.Random, files: Files) -> tuple[str, Files]:
    """Rows deleted, shuffled, truncated; headers dropped; empty files; odd separators."""
    out = dict(files)
    name = rng.choice(_data_files(files))
    text = str(out[name])
    lines = text.splitlines()
    at = rng.randrange(1, len(lines))
    cut = rng.randrange(len(text))
    drop = set(rng.sample(range(1, len(lines)), min(10, len(lines) - 1)))
    options: list[tuple[str, Callable[[], str]]] = [
        ("10 random rows deleted", lambda: "\n".join(
            ln for i, ln in enumerate(lines) if i not in drop)),
        ("header only", lambda: lines[0] + "\n"),
        ("no header", lambda: "\n".join(lines[1:])),
        ("empty file", lambda: ""),
        ("CRLF line ends", lambda: text.replace("\n", "\r\n")),
        ("tab separators", lambda: text.replace(",", "\t").replace(" ", "\t")),
        ("semicolon separators", lambda: text.replace(",", ";")),
        ("extra field", lambda: "\n".join(lines[:at] + [lines[at] + (_sep(name) or " ") + "7"]
                                          + lines[at + 1:])),
        ("missing field", lambda: "\n".join(lines[:at] + [lines[at][:lines[at].rfind(
            _sep(name) or " ")]] + lines[at + 1:])),
        ("shuffled rows", lambda: "\n".join([lines[0], *rng.sample(lines[1:],
                                                                    len(lines) - 1)])),
        ("reversed rows", lambda: "\n".join([lines[0], *reversed(lines[1:])])),
        ("truncated mid-line", lambda: text[:cut]),
        ("appended twice", lambda: text + text),
        ("trailing garbage", lambda: text + "hello world\n"),
        ("header renamed", lambda: "\n".join([lines[0].upper() + "x", *lines[1:]])),
    ]
    what, make = rng.choice(options)
    out[name] = make()
    return f"{name}: {what} (line {at + 1}, byte {cut})", out


@mutator("ins-binary")
def fam_binary(rng: random.Random, files: Files) -> tuple[str, Files]:
    """Binary junk, NUL bytes, invalid UTF-8, UTF-16, a BOM in one file (sidecar too)."""
    out = dict(files)
    name = rng.choice(list(files))
    what, out[name] = binary_variant(rng, str(out[name]).encode("utf-8"))
    return f"{name}: {what}", out


@mutator("ins-time")
def fam_time(rng: random.Random, files: Files) -> tuple[str, Files]:
    """Time stamps repeated, going back, jumping by 1e6 s or 1e300, all equal; GNSS
    outside the IMU span."""
    out = dict(files)
    name = rng.choice([n for n in _data_files(files) if "metadata" not in n])
    sep = _sep(name)
    lines = str(out[name]).splitlines()
    i = rng.randrange(2, len(lines))
    rows = [_split(ln, sep) for ln in lines]
    choice = rng.randrange(6)
    if choice == 0:
        rows[i][0] = rows[i - 1][0]
        what = f"line {i + 1} repeats the previous stamp"
    elif choice == 1:
        rows[i][0], rows[i - 1][0] = rows[i - 1][0], rows[i][0]
        what = f"lines {i} and {i + 1} swap stamps"
    elif choice == 2:
        for r in rows[i:]:
            r[0] = repr(float(r[0]) + 1e6)
        what = f"a 1e6 s gap before line {i + 1}"
    elif choice == 3:
        rows[i][0] = "1e300"
        what = f"line {i + 1} at t = 1e300"
    elif choice == 4:
        for r in rows[1:]:
            r[0] = rows[1][0]
        what = "every stamp equal"
    else:
        for r in rows[1:]:
            r[0] = repr(float(r[0]) - 1e5)
        what = "every stamp 1e5 s earlier (the other stream does not overlap)"
    out[name] = "\n".join(_join(r, sep) for r in rows) + "\n"
    return f"{name}: {what}", out


_KEY = re.compile(r"^(\w+)\s*=\s*(.+)$")
_VALUES = ("0", "-1", "1e300", "-1e300", "inf", "nan", "5e-324", '"text"', "[1, 2]", "true",
           "{}")


@mutator("ins-settings")
def fam_settings(rng: random.Random, files: Files) -> tuple[str, Files]:
    """One sidecar key (KITTI: one metadata value) deleted or set to 0, -1, 1e300, inf,
    nan, 5e-324, a string, a list, a bool; or a whole table deleted."""
    out = dict(files)
    if SIDE in files:
        lines = str(out[SIDE]).splitlines()
        keys = [i for i, ln in enumerate(lines) if _KEY.match(ln)]
        i = rng.choice(keys)
        key = _KEY.match(lines[i]).group(1)  # type: ignore[union-attr]
        if rng.random() < 0.15:
            head = max(k for k in range(i + 1) if lines[k].startswith("["))
            end = next((k for k in range(head + 1, len(lines)) if lines[k].startswith("[")),
                       len(lines))
            what = f"table {lines[head]} deleted"
            lines = lines[:head] + lines[end:]
        elif rng.random() < 0.2:
            what = f"{key} deleted"
            del lines[i]
        else:
            v = rng.choice(_VALUES)
            lines[i] = f"{key} = {v}"
            what = f"{key} = {v}"
        out[SIDE] = "\n".join(lines) + "\n"
        return f"sidecar: {what}", out
    name = f"{KDIR}/{KITTI_NAMES[2]}"
    head, vals = str(out[name]).splitlines()[:2]
    parts = vals.split(" ")
    j = rng.randrange(len(parts))
    v = rng.choice(["0", "-1", "1e300", "nan", "1e-320", "100", "1"])
    parts[j] = v
    out[name] = head + "\n" + " ".join(parts) + "\n"
    return f"metadata {head.split()[j]} = {v}", out


_PATHS = ("/dev/zero", "/dev/null", "missing.csv", "missing_dir")


@mutator("ins-path")
def fam_path(rng: random.Random, files: Files) -> tuple[str, Files]:
    """``--log`` at /dev/zero, /dev/null, a missing file, a folder without the files; the
    KITTI folder with one file missing."""
    if rng.random() < 0.5 and any(n.startswith(KDIR) for n in files):
        out = dict(files)
        gone = rng.choice([n for n in files if n.startswith(KDIR)])
        del out[gone]
        return f"{gone} missing", out
    return f"--log {rng.choice(_PATHS)}", {"@target": rng.choice(_PATHS)}


def ins_cases(n: int, seed: int, families: list[str] | None = None) -> list[Case]:
    """``n`` cases for ``seed`` alternating the CSV and the KITTI base; case ``i`` uses
    family ``i mod F``."""
    bases = {"csv": csv_base(), "kitti": kitti_base()}
    out = []
    for k, (rng, family) in enumerate(seeded_families(n, seed, "ins",
                                                      families or list(INS_FAMILIES))):
        bname = ("csv", "kitti")[k % 2]
        name, files = INS_FAMILIES[family](rng, bases[bname])
        if "@target" in files:
            out.append(Case("log", family, name, bname, None, target=str(files["@target"]),
                            world_kind=INS_KIND))
            continue
        extra = tuple((p, v if isinstance(v, bytes) else v.encode("utf-8"))
                      for p, v in files.items())
        target = CSV if bname == "csv" else KDIR
        if bname == "kitti" and not any(p.startswith(KDIR) for p in files):
            target = KDIR
        out.append(Case("log", family, name, bname, None, extra, target=target,
                        world_kind=INS_KIND))
    return out


def write_files(files: Files, folder: Path) -> None:
    for rel, v in files.items():
        p = folder / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(v if isinstance(v, bytes) else v.encode("utf-8"))
