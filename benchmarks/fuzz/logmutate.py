"""Seeded mutators for GTSAM-format planar logs (``victoria_park.txt``'s layout)::

    ODOMETRY i j dx dy dθ cxx cxy cxθ cyy cyθ cθθ
    LANDMARK i j dx dy cxx cxy cyy

Each family is ``f(rng, lines) -> (name, bytes | path)`` over the truncated log's lines;
:func:`log_cases` wraps the results in :class:`~benchmarks.fuzz.core.Case` records.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from pathlib import Path

from .core import LOG_KIND, Case, binary_variant, registrar, seeded_families

FIELDS = {
    "ODOMETRY": ("tag", "i", "j", "dx", "dy", "dθ", "cxx", "cxy", "cxθ", "cyy", "cyθ", "cθθ"),
    "LANDMARK": ("tag", "i", "j", "dx", "dy", "cxx", "cxy", "cyy"),
}
DIAG = {"ODOMETRY": (6, 9, 11), "LANDMARK": (5, 7)}
OFFDIAG = {"ODOMETRY": (7, 8, 10), "LANDMARK": (6,)}

Result = tuple[str, bytes | str]
LogFamily = Callable[[random.Random, list[str]], Result]

LOG_FAMILIES: dict[str, LogFamily] = {}
"""Log mutator families, by name, in definition order (each added by ``@mutator``)."""
mutator = registrar(LOG_FAMILIES)


def find_victoria() -> Path:
    """GTSAM's example ``victoria_park.txt``."""
    import gtsam

    return Path(gtsam.findExampleDataFile("victoria_park.txt"))


def load_log_lines(path: Path | None = None, n: int = 300) -> list[str]:
    """The first ``n`` record lines of a log (default: GTSAM's Victoria Park)."""
    text = (path or find_victoria()).read_text(encoding="utf-8")
    return [ln for ln in text.splitlines() if ln.strip()][:n]


def _join(lines: list[str]) -> bytes:
    return ("\n".join(lines) + "\n").encode("utf-8")


def _rows(lines: list[str], tag: str) -> list[int]:
    return [i for i, ln in enumerate(lines) if ln.split()[:1] == [tag]]


def _set(lines: list[str], i: int, j: int, tok: str) -> None:
    t = lines[i].split()
    t[j] = tok
    lines[i] = " ".join(t)


def _scope(rng: random.Random, lines: list[str], tag: str) -> tuple[str, list[int]]:
    rows = _rows(lines, tag)
    if rng.random() < 0.5:
        i = rng.choice(rows)
        return f"line {i + 1}", [i]
    return f"every {tag}", rows


# --------------------------------------------------------------------------- families

_TOKENS = ("1_000", "1e300", "-1e300", "nan", "inf", "-inf", "1e-320", "0x10", "١٢٣",
           "٣٫٥", "+5", "1.5", "-1", "9223372036854775808", "18446744073709551616",
           "9" * 30, "1,5", "0", "-0", "1e", "１２", "1" * 5000)


@mutator("log-number")
def fam_number(rng: random.Random, lines: list[str]) -> Result:
    """One number or id replaced by a hostile token (``1_000``, ``1e300``, ``١٢٣`` ...)."""
    out = list(lines)
    i = rng.randrange(len(out))
    tag = out[i].split()[0]
    j = rng.randrange(1, len(FIELDS[tag]))
    old = out[i].split()[j] if j < len(out[i].split()) else None
    tok = rng.choice([t for t in _TOKENS if t != old])  # a change, never the same token
    _set(out, i, j, tok)
    shown = tok if len(tok) < 20 else f"{tok[:3]}...({len(tok)} chars)"
    return f"line {i + 1} {tag} {FIELDS[tag][j]} = {shown!r}", _join(out)


@mutator("log-cov")
def fam_cov(rng: random.Random, lines: list[str]) -> Result:
    """Covariances of one line or every line set to 1e-300, 1e300, 0, -1 or non-PD."""
    out = list(lines)
    tag = rng.choice(list(DIAG))
    where, rows = _scope(rng, out, tag)
    what, diag, off = rng.choice([
        ("diagonal 1e-300", "1e-300", None), ("diagonal 1e300", "1e300", None),
        ("diagonal 0", "0", None), ("diagonal -1", "-1", None),
        ("diagonal 5e-324", "5e-324", None), ("off-diagonal 1e300", None, "1e300"),
        ("all entries 1e-300", "1e-300", "1e-300"),
    ])
    for i in rows:
        for j in DIAG[tag] if diag is not None else ():
            _set(out, i, j, diag)
        for j in OFFDIAG[tag] if off is not None else ():
            _set(out, i, j, off)
    return f"{where}: {tag} covariance {what}", _join(out)


@mutator("log-geometry")
def fam_geometry(rng: random.Random, lines: list[str]) -> Result:
    """Degenerate geometry: range-0 landmarks, repeated or conflicting sightings, broken
    chains, zero or huge motion, shared ids."""
    out = list(lines)
    lms, odo = _rows(out, "LANDMARK"), _rows(out, "ODOMETRY")
    k = rng.choice(lms)
    t = out[k].split()
    poses = [ln.split()[2] for ln in (out[i] for i in odo)]
    choice = rng.randrange(12)
    if choice == 0:
        where, rows = _scope(rng, out, "LANDMARK")
        for i in rows:
            _set(out, i, 3, "0")
            _set(out, i, 4, "0")
        name = f"{where}: landmark at range 0"
    elif choice == 1:
        n = rng.choice([2, 5])
        out[k + 1:k + 1] = [out[k]] * (n - 1)
        name = f"line {k + 1}: sighting repeated {n} times"
    elif choice == 2:
        out.insert(k + 1, " ".join([*t[:3], str(float(t[3]) + 10.0), *t[4:]]))
        name = f"line {k + 1}: conflicting second sighting (x + 10 m)"
    elif choice == 3:
        _set(out, k, 2, rng.choice(poses))
        name = f"line {k + 1}: landmark id equals a pose id"
    elif choice == 4:
        i = rng.choice(odo)
        _set(out, i, 2, out[i].split()[1])
        name = f"line {i + 1}: odometry from a pose to itself"
    elif choice == 5:
        last = out[odo[-1]].split()[2]
        out.append(f"ODOMETRY {last} 0 0 0 0 0.0001 0 0 4e-06 0 4e-06")
        name = "loop closure back to pose 0"
    elif choice == 6:
        for i in odo:
            for j in (3, 4, 5):
                _set(out, i, j, "0")
        name = "every odometry is zero motion"
    elif choice == 7:
        for i in odo:
            _set(out, i, 5, "1000")
        name = "every odometry turns 1000 rad"
    elif choice == 8:
        _set(out, k, 3, "1e12")
        name = f"line {k + 1}: landmark 1e12 m away"
    elif choice == 9:
        out.insert(0, out.pop(k))
        name = f"line {k + 1}: sighting moved before the first odometry"
    elif choice == 10:
        for i in lms:
            _set(out, i, 2, t[2])
        name = "every sighting has the same landmark id"
    else:
        _set(out, k, 3, "1e-300")
        _set(out, k, 4, "0")
        name = f"line {k + 1}: landmark at range 1e-300"
    return name, _join(out)


@mutator("log-structure")
def fam_structure(rng: random.Random, lines: list[str]) -> Result:
    """Lines deleted, shuffled, truncated, retagged; empty files, odd separators."""
    out = list(lines)
    at = rng.randrange(len(out))
    text = "\n".join(out) + "\n"
    cut = rng.randrange(len(text))
    drop = set(rng.sample(range(len(out)), 10))
    options: list[tuple[str, Callable[[], str]]] = [
        ("10 random lines deleted",
         lambda: "\n".join(ln for i, ln in enumerate(out) if i not in drop)),
        ("no ODOMETRY lines", lambda: "\n".join(ln for ln in out if "ODOMETRY" not in ln)),
        ("no LANDMARK lines", lambda: "\n".join(ln for ln in out if "LANDMARK" not in ln)),
        ("first line only", lambda: out[0]),
        ("one LANDMARK line only", lambda: next(ln for ln in out if "LANDMARK" in ln)),
        ("empty file", lambda: ""),
        ("comments and blank lines only", lambda: "# nothing\n\n   \n# here\n"),
        ("CRLF line ends", lambda: text.replace("\n", "\r\n")),
        ("tab separators", lambda: text.replace(" ", "\t")),
        ("extra token", lambda: "\n".join(out[:at] + [out[at] + " 7"] + out[at + 1:])),
        ("missing token", lambda: "\n".join(out[:at] + [out[at].rsplit(" ", 1)[0]]
                                            + out[at + 1:])),
        ("lowercase tag", lambda: "\n".join(out[:at] + [out[at].lower()] + out[at + 1:])),
        ("unknown tag", lambda: "\n".join(out[:at] + ["VERTEX_SE2 0 0 0 0"] + out[at:])),
        ("shuffled lines", lambda: "\n".join(rng.sample(out, len(out)))),
        ("reversed lines", lambda: "\n".join(reversed(out))),
        ("truncated mid-line", lambda: text[:cut]),
        ("log appended twice", lambda: text + text),
        ("trailing garbage", lambda: text + "hello world\n"),
    ]
    name, make = rng.choice(options)
    return f"{name} (line {at + 1}, byte {cut})", make().encode("utf-8")


@mutator("log-binary")
def fam_binary(rng: random.Random, lines: list[str]) -> Result:
    """Binary junk, NUL bytes, invalid UTF-8, UTF-16, a BOM."""
    return binary_variant(rng, _join(lines))


@mutator("log-huge")
def fam_huge(rng: random.Random, lines: list[str]) -> Result:
    """Pose ids at or beyond 2**63, and thousands of new landmarks at one pose."""
    out = list(lines)
    odo, lms = _rows(out, "ODOMETRY"), _rows(out, "LANDMARK")
    choice = rng.randrange(4)
    if choice in (0, 1):
        shift, mul = (2**63, 1) if choice == 0 else (0, 10**15)
        for i in odo + lms:
            t = out[i].split()
            j_is_pose = t[0] == "ODOMETRY"
            t[1] = str(int(t[1]) * mul + shift)
            t[2] = str(int(t[2]) * mul + shift) if j_is_pose else t[2]
            out[i] = " ".join(t)
        name = "pose ids + 2**63" if choice == 0 else "pose ids x 1e15 (still < 2**63)"
    else:
        n = 3000 if choice == 2 else 300
        last = out[odo[-1]].split()[2]
        out += [f"LANDMARK {last} {10**6 + m} {5.0 + m % 20} {m % 7 - 3.0} 0.4 0 0.4"
                for m in range(n)]
        name = f"{n} new landmarks seen from the last pose"
    return name, _join(out)


def _huge_ints(rng: random.Random) -> tuple[str, str]:
    """A hostile integer token and its description: beyond int64 or GTSAM's 56-bit key
    index, or with more digits than Python converts by default (4 300)."""
    digits = rng.choice([4300, 4301, 5000, 20_000])
    return rng.choice([
        (str(2**56), "2**56"), (str(2**63), "2**63"), (str(2**64), "2**64"),
        (str(10**19), "1e19"), (str(10**100), "1e100"), ("+" + str(2**63), "+2**63"),
        ("1" * digits, f"a {digits}-digit id"), ("0" * (digits - 1) + "7",
                                                f"7 with {digits - 1} leading zeros"),
        ("-" + "9" * digits, f"a negative {digits}-digit id"),
    ])


@mutator("log-huge-int")
def fam_huge_int(rng: random.Random, lines: list[str]) -> Result:
    """A pose or landmark id beyond int64, or of thousands of digits, in one line or every
    line (a 5000-digit id hit Python's int-digits limit: a ValueError traceback)."""
    out = list(lines)
    tok, what = _huge_ints(rng)
    tag, j, role = rng.choice([("ODOMETRY", 1, "from-pose"), ("ODOMETRY", 2, "to-pose"),
                               ("LANDMARK", 1, "pose"), ("LANDMARK", 2, "landmark")])
    rows = _rows(out, tag)
    if rng.random() < 0.7:
        i = rng.choice(rows)
        _set(out, i, j, tok)
        where = f"line {i + 1}"
    else:
        for i in rows:
            _set(out, i, j, tok)
        where = f"every {tag}"
    return f"{where}: {tag} {role} id = {what}", _join(out)


_PATHS = ("/dev/zero", "/dev/null", ".", "missing.txt", "/etc/passwd")


@mutator("log-path")
def fam_path(rng: random.Random, lines: list[str]) -> Result:
    """``--log`` pointing at /dev/zero, /dev/null, a folder, a missing file."""
    target = rng.choice(_PATHS)
    return f"--log {target}", target


def log_cases(n: int, seed: int, lines: list[str],
              families: list[str] | None = None) -> list[Case]:
    """``n`` log cases for ``seed``: case ``i`` uses family ``i mod F``."""
    out = []
    for rng, family in seeded_families(n, seed, "log", families or list(LOG_FAMILIES)):
        name, result = LOG_FAMILIES[family](rng, lines)
        if isinstance(result, str):
            out.append(Case("log", family, name, "victoria", None, target=result,
                            world_kind=LOG_KIND))
        else:
            out.append(Case("log", family, name, "victoria", result, world_kind=LOG_KIND))
    return out
