"""Provenance of a campaign: which code, which input, which command, when, how long, on
what.  :func:`provenance` builds the ``provenance`` block of ``summary.json``;
:func:`provenance_rows` and :func:`provenance_line` render it in the reports;
:func:`version_text` is what ``slam --version`` prints.

Every item is best effort: a missing git, an unreadable world file or an uninstalled
distribution leaves that item ``None`` with its ``<key>_reason`` beside it, never an error.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import os
import platform
import shlex
import subprocess
import sys
from collections.abc import Sequence
from importlib import metadata
from importlib.resources import files
from pathlib import Path
from typing import Any

DISTRIBUTION = "navfilters"
LIBRARIES = ("numpy", "scipy", "gtsam", "matplotlib")
_ROOT = Path(__file__).resolve().parents[2]  # the source tree (a git work tree, if any)


def package_version(dist: str = DISTRIBUTION) -> str | None:
    """The installed version of ``dist`` (None if it is not installed)."""
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", "-C", str(_ROOT), *args], capture_output=True,
                             text=True, timeout=5, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def git_commit() -> tuple[str | None, bool | None]:
    """``(commit, dirty)`` of the source tree this package runs from, or ``(None, None)``
    outside a git work tree; ``dirty`` is True when tracked files differ from the commit."""
    commit = _git("rev-parse", "HEAD")
    if not commit:
        return None, None
    status = _git("status", "--porcelain", "--untracked-files=no")
    return commit, None if status is None else bool(status)


def file_sha256(source: str | os.PathLike[str] | None) -> str | None:
    """SHA-256 of a world or log file: a path, or a bundled world's ``worlds/<name>.toml``
    (read from the installed package); None if it cannot be read."""
    if source is None:
        return None
    text = os.fspath(source)
    candidates: list[Any] = [Path(text)]
    if text.startswith("worlds/"):
        candidates.append(files("worlds") / text.split("/", 1)[1])
    for c in candidates:
        try:
            if c.is_file():
                return hashlib.sha256(c.read_bytes()).hexdigest()
        except OSError:
            continue
    return None


def provenance(*, argv: Sequence[str] | None = None, source: str | None = None,
               seed: int | None = None, runs: int | None = None, workers: int | None = None,
               scheduler: str | None = None, started: dt.datetime | None = None,
               wall_time_s: float | None = None) -> dict[str, Any]:
    """The ``provenance`` block of ``summary.json``.

    argv : the command line (default ``sys.argv``, program name shortened to its base
        name); source : the world file (or log) read; seed, runs : the campaign's;

    workers / scheduler : the local pool's size or the Dask scheduler's address;
    started : when the campaign started (default: now minus ``wall_time_s``),
    wall_time_s : how long it took.
    """
    argv = list(sys.argv if argv is None else argv)
    if argv:
        argv[0] = os.path.basename(argv[0])
    commit, dirty = git_commit()
    started = started or (dt.datetime.now(dt.UTC) - dt.timedelta(seconds=wall_time_s or 0.0))
    block = {
        "package": DISTRIBUTION,
        "version": package_version(),
        "git_commit": commit,
        "git_dirty": dirty,
        "command": shlex.join(argv),
        "world_file": source,
        "world_sha256": file_sha256(source),
        "seed": seed,
        "runs": runs,
        "started_utc": started.astimezone(dt.UTC).isoformat(timespec="seconds"),
        "wall_time_s": None if wall_time_s is None else round(float(wall_time_s), 3),
        "workers": None if scheduler else workers,
        "scheduler": scheduler,
        "python": platform.python_version(),
        "platform": platform.platform(terse=True),
        "libraries": {name: package_version(name) for name in LIBRARIES},
    }
    return {**block, **_reasons(block)}


def _reasons(block: dict[str, Any]) -> dict[str, str]:
    """``<key>_reason`` for each item left ``None`` (:mod:`slam.nulls`)."""
    why = {"version": f"{DISTRIBUTION} is not installed as a distribution",
           "git_commit": "no git work tree (or no git) at the source",
           "git_dirty": "no git work tree (or no git) at the source",
           "world_file": "the world was not read from a file",
           "world_sha256": ("no world file" if block["world_file"] is None
                            else "the world file cannot be read"),
           "seed": "not given", "runs": "not given", "wall_time_s": "not measured",
           "workers": "the runs went to the Dask scheduler",
           "scheduler": "the runs went to the local process pool (workers)"}
    out = {f"{k}_reason": v for k, v in why.items() if block.get(k) is None}
    missing = [n for n, v in block["libraries"].items() if v is None]
    if missing:
        out["libraries_reason"] = f"not installed: {', '.join(missing)}"
    return out


def version_text() -> str:
    """``slam --version``: the distribution's version, the commit, Python and libraries."""
    commit, dirty = git_commit()
    parts = [f"{DISTRIBUTION} {package_version() or '(not installed)'}"]
    if commit:
        parts.append(f"commit {commit[:12]}{' (modified)' if dirty else ''}")
    parts.append(f"Python {platform.python_version()}")
    libs = ", ".join(f"{n} {package_version(n) or '-'}" for n in LIBRARIES)
    return "; ".join(parts) + f"\n{libs}"


_LABELS = (("version", "package version"), ("git_commit", "git commit"),
           ("command", "command line"), ("world_file", "world / log file"),
           ("world_sha256", "file SHA-256"), ("seed", "seed"), ("runs", "runs"),
           ("started_utc", "started (UTC)"), ("wall_time_s", "wall time (s)"),
           ("workers", "local workers"), ("scheduler", "Dask scheduler"),
           ("python", "Python"), ("platform", "platform"), ("libraries", "libraries"))


def _text(key: str, value: Any, block: dict[str, Any]) -> str:
    if key == "git_commit" and block.get("git_dirty"):
        return f"{value} (with uncommitted changes)"
    if key == "version":
        return f"{block.get('package', DISTRIBUTION)} {value}"
    if isinstance(value, dict):
        return ", ".join(f"{k} {v if v is not None else '-'}" for k, v in value.items())
    return str(value)


def provenance_rows(block: Any) -> list[list[str]]:
    """``[label, value]`` rows of a provenance block (items that are None left out)."""
    if not isinstance(block, dict):
        return []
    return [[label, _text(key, block[key], block)] for key, label in _LABELS
            if block.get(key) is not None]


def provenance_line(block: Any) -> str:
    """One line for under a report's title: version, commit, date, wall time, executor."""
    if not isinstance(block, dict):
        return ""
    bits = [f"{block.get('package', DISTRIBUTION)} {block.get('version') or '?'}"]
    if block.get("git_commit"):
        bits.append(f"commit {str(block['git_commit'])[:12]}"
                    + (" (modified)" if block.get("git_dirty") else ""))
    if block.get("started_utc"):
        bits.append(f"started {block['started_utc']}")
    if block.get("wall_time_s") is not None:
        bits.append(f"{block['wall_time_s']:.1f} s wall")
    if block.get("scheduler"):
        bits.append(f"Dask scheduler {block['scheduler']}")
    elif block.get("workers") is not None:
        bits.append(f"{block['workers']} local worker{'s' if block['workers'] != 1 else ''}")
    return "Provenance: " + ", ".join(bits) + " (details at the end)."
