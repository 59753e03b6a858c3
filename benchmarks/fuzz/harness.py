"""Run fuzz cases through the ``slam`` CLI in a limited child process and classify them.

Each case runs in its own folder (the child's working directory) as::

    slam run case.toml --runs 1 --workers 1 --no-plots --out out
    slam run --log case.txt --filters srckf --no-plots --out out

with a wall-time limit (the whole process group is killed past it) and an address-space
limit (``RLIMIT_AS``). Outcome classes (:data:`CLASSES`):

``ok``                exit 0 and ``summary.json`` holds no degenerate score
``rejected``          exit 2, exactly one stderr line ``error: ...`` naming the file or
                      an option, and nothing written to ``--out``
``traceback``         a ``Traceback`` on stderr, or exit 1
``hang``              killed at the time limit
``memory``            ``MemoryError`` / failed allocation under the memory limit
``crash``             killed by a signal, or an exit code other than 0, 1, 2
``wrote-on-error``    a non-zero exit that left ``--out`` behind
``degenerate-success`` exit 0 with a missing or degenerate ``summary.json``
``multi-line-error``  exit 2 with no, or more than one, stderr line
``unnamed-error``     exit 2 with one line that is not ``error: ...`` naming the file/option
``harness-error``     the harness itself failed on the case (a bug here, not in ``slam``)
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .core import Case

CLASSES = ("ok", "rejected", "traceback", "hang", "memory", "crash", "wrote-on-error",
           "degenerate-success", "multi-line-error", "unnamed-error", "harness-error")
GOOD = frozenset({"ok", "rejected"})
_MEMORY = ("MemoryError", "Unable to allocate", "std::bad_alloc", "Cannot allocate memory",
           "out of memory")
_METRIC = re.compile(r"rmse|_err|dist|mean_abs")


@dataclass(frozen=True)
class Limits:
    """Per-case limits: wall seconds, address-space bytes, largest file written."""

    seconds: float = 60.0
    memory_bytes: int = 4 << 30
    file_bytes: int = 1 << 30


@dataclass
class Outcome:
    """What one case did: its class, exit code, time, a detail line and stderr's tail."""

    case: Case
    klass: str
    rc: int | None
    seconds: float
    detail: str
    stderr_tail: str = ""
    written: list[str] = field(default_factory=list)

    def record(self) -> dict[str, Any]:
        """A JSON-ready summary (no file contents)."""
        return {"id": self.case.ident, "kind": self.case.kind, "family": self.case.family,
                "base": self.case.base, "mutation": self.case.name, "class": self.klass,
                "rc": self.rc, "seconds": round(self.seconds, 2), "detail": self.detail}


def default_slam() -> list[str]:
    """The ``slam`` script next to this interpreter, else the one on ``PATH``."""
    here = Path(sys.executable).with_name("slam")
    found = str(here) if here.exists() else shutil.which("slam")
    if not found:
        raise FileNotFoundError("no `slam` command next to the interpreter or on PATH")
    return [found]


_LAUNCHER = (
    "import os, resource, sys\n"
    "mem, fsize = int(sys.argv[1]), int(sys.argv[2])\n"
    "resource.setrlimit(resource.RLIMIT_AS, (mem, mem))\n"
    "resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))\n"
    "resource.setrlimit(resource.RLIMIT_CORE, (0, 0))\n"
    "os.execvp(sys.argv[3], sys.argv[3:])\n"
)


def limited(argv: list[str], limits: Limits) -> list[str]:
    """``argv`` behind a launcher that sets the limits and then ``exec``s it (no
    ``preexec_fn``, which is unsafe with threads)."""
    return [sys.executable, "-c", _LAUNCHER, str(limits.memory_bytes), str(limits.file_bytes),
            *argv]


def child_env() -> dict[str, str]:
    """The child's environment: one BLAS thread, no figures on screen, no bytecode."""
    env = dict(os.environ)
    env.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1",
               MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1", PYTHONUNBUFFERED="1")
    return env


def write_case(case: Case, folder: Path) -> Path:
    """Write the case's input (and side files) into ``folder``; return what to pass."""
    folder.mkdir(parents=True, exist_ok=True)
    for rel, data in case.extra:
        path = folder / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    name = "case.toml" if case.kind == "world" else "case.txt"
    if case.data is not None:
        (folder / name).write_bytes(case.data)
    return Path(case.target) if case.target is not None else Path(name)


def command(slam: list[str], case: Case, target: Path, out: Path) -> list[str]:
    """The ``slam run`` command line for a case."""
    if case.kind == "world":
        return [*slam, "run", str(target), "--runs", "1", "--workers", "1", "--no-plots",
                "--out", str(out)]
    return [*slam, "run", "--log", str(target), "--filters", "srckf", "--no-plots",
            "--out", str(out)]


_LIVE: set[subprocess.Popen[bytes]] = set()
_LIVE_LOCK = threading.Lock()


def kill_all() -> None:
    """Kill the process group of every case still running (on interrupt)."""
    with _LIVE_LOCK:
        for proc in _LIVE:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)


def execute(argv: list[str], cwd: Path, limits: Limits) -> tuple[int | None, float, str]:
    """Run ``argv`` in its own process group; -> (exit code or None on timeout, s, stderr)."""
    t0 = time.perf_counter()
    with open(cwd / ".stdout", "wb") as out, open(cwd / ".stderr", "wb") as err:
        proc = subprocess.Popen(limited(argv, limits), cwd=cwd, stdin=subprocess.DEVNULL,
                                stdout=out, stderr=err, env=child_env(),
                                start_new_session=True)
        with _LIVE_LOCK:
            _LIVE.add(proc)
        try:
            rc: int | None = proc.wait(timeout=limits.seconds)
        except subprocess.TimeoutExpired:
            rc = None
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)  # the run and anything it left behind
            proc.wait()
            with _LIVE_LOCK:
                _LIVE.discard(proc)
    seconds = time.perf_counter() - t0
    stderr = (cwd / ".stderr").read_bytes()[-200_000:].decode("utf-8", "replace")
    return rc, seconds, stderr


def run_case(case: Case, workdir: Path, slam: list[str], limits: Limits,
             keep_folder: bool = False, folder_name: str | None = None) -> Outcome:
    """Run one case in ``workdir/<folder_name or case id>`` and classify it (a harness
    fault becomes class ``harness-error`` rather than stopping a campaign)."""
    folder = workdir / (folder_name or case.ident)
    try:
        return _run_in(case, folder, slam, limits, keep_folder)
    except Exception as exc:  # noqa: BLE001 - reported as a class of its own
        return Outcome(case, "harness-error", None, 0.0, f"{type(exc).__name__}: {exc}")


def _run_in(case: Case, folder: Path, slam: list[str], limits: Limits, keep_folder: bool
            ) -> Outcome:
    target = write_case(case, folder)
    out = Path("out")
    rc, seconds, stderr = execute(command(slam, case, target, out), folder, limits)
    written = sorted(str(p.relative_to(folder)) for p in (folder / out).rglob("*"))
    if (folder / out).exists() and not written:
        written = ["out/ (empty folder)"]
    names = [target.name, str(target)] if case.target is None else [str(target)]
    klass, detail = classify(rc, stderr, written, folder / out / "summary.json", names)
    tail = "\n".join(stderr.rstrip().splitlines()[-40:])
    if not keep_folder:
        shutil.rmtree(folder, ignore_errors=True)
    return Outcome(case, klass, rc, seconds, detail, tail, written)


# --------------------------------------------------------------------------- classifier

_EXC = re.compile(r"^([A-Za-z_][\w.]*(Error|Exception|Exit|Interrupt|Warning))(: ?(.*))?$")
_WARN = re.compile(r"\b\w+Warning: .*")


def explain(stderr: str) -> str:
    """The most telling stderr line: the last exception (with the next line when GTSAM
    puts its message there), else the last warning, else the last line."""
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    for i in range(len(lines) - 1, -1, -1):
        m = _EXC.match(lines[i])
        if m and not m.group(1).endswith("Warning"):
            text = lines[i]
            if not (m.group(4) or "").strip() and i + 1 < len(lines):
                text = f"{text.rstrip(': ')}: {lines[i + 1]}"
            return text
    for line in reversed(lines):
        w = _WARN.search(line)
        if w:
            return w.group(0)
    return lines[-1] if lines else ""


def classify(rc: int | None, stderr: str, written: list[str], summary: Path,
             names: list[str]) -> tuple[str, str]:
    """-> (class, detail) for one finished run; ``names`` are how the input may be named."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    last = lines[-1].strip() if lines else ""
    if rc is None:
        return "hang", f"killed at the time limit; {explain(stderr)}".rstrip("; ")
    if any(m in stderr for m in _MEMORY):
        return "memory", explain(stderr)
    if "Traceback" in stderr or rc == 1:
        return "traceback", explain(stderr) or f"exit {rc}, no message"
    if rc < 0:
        return "crash", f"killed by {signal.Signals(-rc).name}; {explain(stderr)}"
    if rc not in (0, 2):
        return "crash", f"exit {rc}; {explain(stderr)}"
    if rc == 0:
        reason = degenerate_reason(summary)
        if reason:
            return "degenerate-success", reason
        return "ok", f"{len(lines)} stderr lines, e.g. {explain(stderr)}" if lines else ""
    if written:
        return "wrote-on-error", f"left {', '.join(written[:5])}; {last}"
    if len(lines) != 1:
        return "multi-line-error", f"{len(lines)} stderr lines; {last}"
    if not last.startswith("error:"):
        return "unnamed-error", last
    if not any(n and n in last for n in names) and " --" not in last:
        return "unnamed-error", last
    return "rejected", last


def _leaves(obj: Any, path: str = "") -> list[tuple[str, Any]]:
    if isinstance(obj, dict):
        return [x for k, v in obj.items() for x in _leaves(v, f"{path}.{k}" if path else k)]
    if isinstance(obj, list):
        return [x for i, v in enumerate(obj) for x in _leaves(v, f"{path}[{i}]")]
    return [(path, obj)]


def _num(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def degenerate_reason(summary: Path) -> str | None:
    """Why a successful run's ``summary.json`` is not a real score, or ``None``."""
    try:
        data = json.loads(summary.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        return f"no readable summary.json ({type(exc).__name__})"
    if not isinstance(data, dict):
        return "summary.json is not an object"
    if not data.get("filters"):
        return "no filter results in summary.json"
    for path, v in _leaves({k: v for k, v in data.items() if k != "paper"}):
        if _num(v) and not math.isfinite(v):
            return f"non-finite value {path} = {v}"
    if "poses" in data and _num(data["poses"]) and data["poses"] < 2:
        return f"a log of {data['poses']} pose(s) presented as scored"
    groups = ("filters", "baselines", "reference")
    for name, entry in ((n, e) for g in groups for n, e in (data.get(g) or {}).items()):
        if not isinstance(entry, dict):
            continue
        metrics = [(p, v) for p, v in _leaves(entry) if _METRIC.search(p) and _num(v)]
        if entry.get("runs_scored", 1) == 0 and metrics:
            return f"{name}: 0 runs scored but {metrics[0][0]} = {metrics[0][1]}"
        if metrics and all(v == 0 for _, v in metrics):
            return f"{name}: every error metric is exactly 0 ({len(metrics)} of them)"
        if entry.get("landmarks_mapped") == 0 and any("landmark" in p for p, _ in metrics):
            return f"{name}: 0 landmarks mapped but landmark distances reported"
    return None


# --------------------------------------------------------------------------- --out probe

def out_probe(slam: list[str], workdir: Path, good: Case, bad: Case, log: Case,
              limits: Limits) -> dict[str, Any]:
    """Run a good world, a rejected world and a good log with ``--out`` set to an existing
    foreign folder holding one file; that file must survive each run unchanged."""
    results: dict[str, Any] = {}
    for label, case in (("good-world", good), ("rejected-world", bad), ("good-log", log)):
        folder = workdir / f"probe-{label}"
        target = write_case(case, folder)
        foreign = folder / "foreign"
        foreign.mkdir()
        (foreign / "precious.txt").write_text("keep me\n")
        rc, seconds, stderr = execute(command(slam, case, target, Path("foreign")), folder,
                                      limits)
        precious = foreign / "precious.txt"
        kept = precious.is_file() and precious.read_text() == "keep me\n"
        results[label] = {"rc": rc, "seconds": round(seconds, 2), "file_kept": kept,
                          "now_in_folder": sorted(p.name for p in foreign.iterdir())[:20],
                          "stderr_last": (stderr.strip().splitlines() or [""])[-1]}
        shutil.rmtree(folder, ignore_errors=True)
    results["passed"] = all(r["file_kept"] for r in results.values() if isinstance(r, dict))
    return results


__all__ = ["CLASSES", "GOOD", "Limits", "Outcome", "classify", "command",
           "default_slam", "degenerate_reason", "execute", "kill_all", "out_probe", "run_case",
           "write_case"]
