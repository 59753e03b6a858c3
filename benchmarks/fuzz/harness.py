"""Run fuzz cases through the ``slam`` CLI in a limited child process and classify them.

Each case runs in its own folder (the child's working directory) as::

    slam run case.toml --runs 1 --workers 1 --no-plots --out out
    slam run --log case.txt --filters srckf --no-plots --out out

with a wall-time limit (the whole process group is killed past it) and an address-space
limit (``RLIMIT_AS``). Outcome classes (:data:`CLASSES`):

``ok``                exit 0, ``summary.json`` holds no degenerate score and no null
                      without its reason, and no warning was printed
``rejected``          exit 2, exactly one stderr line ``error: ...`` naming the file or
                      an option, and nothing written to ``--out``
``traceback``         a ``Traceback`` on stderr, or exit 1
``hang``              killed at the time limit (the detail gives the CPU seconds and the
                      peak memory it had used: busy or blocked, growing or not)
``memory``            ``MemoryError`` / failed allocation under the memory limit
``crash``             killed by a signal, or an exit code other than 0, 1, 2
``wrote-on-error``    a non-zero exit that left ``--out`` behind
``degenerate-success`` exit 0 with a missing or degenerate ``summary.json``
``warning-printed``   exit 0 with a ``...Warning:`` line on stderr (numpy's RuntimeWarning)
``unexplained-null``  exit 0 with a null in ``summary.json`` that has no reason beside it
                      (:func:`~benchmarks.fuzz.verdicts.unexplained_nulls`)
``costly-rejection``  a proper rejection that cost more than ``Limits.reject_cpu_s`` CPU
                      seconds or ``Limits.reject_mib`` MiB (a 20 000-part dotted key: 8 s and
                      2 GB before exit 2): the input was not bounded before it was parsed
``multi-line-error``  exit 2 with no, or more than one, stderr line
``unnamed-error``     exit 2 with one line that is not ``error: ...`` naming the file/option
``harness-error``     the harness itself failed on the case (a bug here, not in ``slam``)

Every record also carries the run's CPU seconds and peak resident memory (``wait4``) and
its ``flags``: every one of ``warning-printed``, ``unexplained-null``, ``degenerate`` and
``near-limit`` (a finished run that used over half the time or memory limit: slow but
bounded, a hang on a slower machine) that applies, whatever the class.
"""

from __future__ import annotations

import contextlib
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
from .verdicts import degenerate_reason, printed_warnings, read_summary, unexplained_nulls

CLASSES = ("ok", "rejected", "traceback", "hang", "memory", "crash", "wrote-on-error",
           "degenerate-success", "warning-printed", "unexplained-null", "costly-rejection",
           "multi-line-error", "unnamed-error", "harness-error")
GOOD = frozenset({"ok", "rejected"})
_MEMORY = ("MemoryError", "Unable to allocate", "std::bad_alloc", "Cannot allocate memory",
           "out of memory")


@dataclass(frozen=True)
class Limits:
    """Per-case limits: wall seconds, address-space bytes, largest file written; and what
    a rejection may cost before it is ``costly-rejection`` (CPU seconds, peak MiB)."""

    seconds: float = 60.0
    memory_bytes: int = 4 << 30
    file_bytes: int = 1 << 30
    reject_cpu_s: float = 5.0
    reject_mib: float = 1024.0


@dataclass(frozen=True)
class Usage:
    """What a finished (or killed) run used: CPU seconds (user + system) and peak
    resident memory (MiB), from ``wait4``."""

    cpu_s: float = 0.0
    peak_mib: float = 0.0


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
    usage: Usage = field(default_factory=Usage)
    flags: tuple[str, ...] = ()
    nulls: tuple[str, ...] = ()

    def record(self) -> dict[str, Any]:
        """A JSON-ready summary (no file contents; the first 10 unexplained nulls)."""
        return {"id": self.case.ident, "kind": self.case.kind, "family": self.case.family,
                "base": self.case.base, "world_kind": self.case.world_kind,
                "mutation": self.case.name, "class": self.klass, "rc": self.rc,
                "seconds": round(self.seconds, 2), "cpu_s": round(self.usage.cpu_s, 2),
                "peak_mib": round(self.usage.peak_mib, 1), "flags": list(self.flags),
                "nulls": list(self.nulls[:10]), "detail": self.detail}


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
    """The ``slam run`` command line for a case (``--no-plots`` unless ``case.plots``)."""
    plots = [] if case.plots else ["--no-plots"]
    if case.kind == "world":
        return [*slam, "run", str(target), "--runs", "1", "--workers", "1", *plots,
                "--out", str(out)]
    return [*slam, "run", "--log", str(target), "--filters", "srckf", *plots,
            "--out", str(out)]


_LIVE: set[subprocess.Popen[bytes]] = set()
_LIVE_LOCK = threading.Lock()


def kill_all() -> None:
    """Kill the process group of every case still running (on interrupt)."""
    with _LIVE_LOCK:
        for proc in _LIVE:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)


def _reap(proc: subprocess.Popen[bytes], block: bool) -> Usage | None:
    """``wait4`` the child: its usage once it has ended (``None`` while it runs)."""
    pid, status, ru = os.wait4(proc.pid, 0 if block else os.WNOHANG)
    if not pid:
        return None
    proc.returncode = os.waitstatus_to_exitcode(status)
    return Usage(ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0)  # Linux: KiB


def execute_usage(argv: list[str], cwd: Path, limits: Limits
                  ) -> tuple[int | None, float, str, Usage]:
    """Run ``argv`` in its own process group; -> (exit code or None on timeout, wall s,
    stderr, CPU and peak memory used)."""
    t0 = time.perf_counter()
    usage: Usage | None = None
    rc: int | None = None
    with open(cwd / ".stdout", "wb") as out, open(cwd / ".stderr", "wb") as err:
        proc = subprocess.Popen(limited(argv, limits), cwd=cwd, stdin=subprocess.DEVNULL,
                                stdout=out, stderr=err, env=child_env(),
                                start_new_session=True)
        with _LIVE_LOCK:
            _LIVE.add(proc)
        try:
            deadline = t0 + limits.seconds
            while (usage := _reap(proc, block=False)) is None:
                if time.perf_counter() >= deadline:
                    break
                time.sleep(0.05)
            if usage is not None:
                rc = proc.returncode
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)  # the run and anything it left behind
            if usage is None:
                with contextlib.suppress(ChildProcessError):
                    usage = _reap(proc, block=True)
            with _LIVE_LOCK:
                _LIVE.discard(proc)
    seconds = time.perf_counter() - t0
    stderr = (cwd / ".stderr").read_bytes()[-200_000:].decode("utf-8", "replace")
    return rc, seconds, stderr, usage or Usage()


def execute(argv: list[str], cwd: Path, limits: Limits) -> tuple[int | None, float, str]:
    """Run ``argv`` in its own process group; -> (exit code or None on timeout, s, stderr)."""
    rc, seconds, stderr, _ = execute_usage(argv, cwd, limits)
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
    rc, seconds, stderr, usage = execute_usage(command(slam, case, target, out), folder,
                                               limits)
    written = sorted(str(p.relative_to(folder)) for p in (folder / out).rglob("*"))
    if (folder / out).exists() and not written:
        written = ["out/ (empty folder)"]
    names = [target.name, str(target)] if case.target is None else [str(target)]
    v = assess(rc, stderr, written, folder / out / "summary.json", names, usage, limits,
               seconds)
    tail = "\n".join(stderr.rstrip().splitlines()[-40:])
    if not keep_folder:
        shutil.rmtree(folder, ignore_errors=True)
    return Outcome(case, v.klass, rc, seconds, v.detail, tail, written, usage, v.flags,
                   v.nulls)


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


@dataclass(frozen=True)
class Verdict:
    """A run's class, its detail line, the flags that apply and its unexplained nulls."""

    klass: str
    detail: str
    flags: tuple[str, ...] = ()
    nulls: tuple[str, ...] = ()


def _mib(n: float) -> str:
    return f"{n / 1024:.1f} GiB" if n >= 1024 else f"{n:.0f} MiB"


def assess(rc: int | None, stderr: str, written: list[str], summary: Path, names: list[str],
           usage: Usage | None = None, limits: Limits | None = None,
           seconds: float = 0.0) -> Verdict:
    """The :class:`Verdict` on one run; ``names`` are how the input may be named, ``usage``
    and ``limits`` tell a costly rejection and a run near its limits."""
    usage, limits = usage or Usage(), limits or Limits()
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    last = lines[-1].strip() if lines else ""
    used = f"cpu {usage.cpu_s:.1f} s, peak {_mib(usage.peak_mib)}"
    if rc is None:
        return Verdict("hang", f"killed at the time limit ({used}); {explain(stderr)}"
                       .rstrip("; "))
    flags: list[str] = []
    if (seconds > limits.seconds / 2 or usage.peak_mib * (1 << 20) > limits.memory_bytes / 2):
        flags.append("near-limit")
    if any(m in stderr for m in _MEMORY):
        return Verdict("memory", f"{explain(stderr)} ({used})", tuple(flags))
    if "Traceback" in stderr or rc == 1:
        return Verdict("traceback", explain(stderr) or f"exit {rc}, no message", tuple(flags))
    if rc < 0:
        return Verdict("crash", f"killed by {signal.Signals(-rc).name}; {explain(stderr)}")
    if rc not in (0, 2):
        return Verdict("crash", f"exit {rc}; {explain(stderr)}")
    if rc == 0:
        return _assess_success(stderr, lines, summary, flags)
    if written:
        return Verdict("wrote-on-error", f"left {', '.join(written[:5])}; {last}")
    if len(lines) != 1:
        return Verdict("multi-line-error", f"{len(lines)} stderr lines; {last}")
    if not last.startswith("error:"):
        return Verdict("unnamed-error", last)
    if not any(n and n in last for n in names) and " --" not in last:
        return Verdict("unnamed-error", last)
    if usage.cpu_s > limits.reject_cpu_s or usage.peak_mib > limits.reject_mib:
        return Verdict("costly-rejection", f"{used} to refuse it; {last}", tuple(flags))
    return Verdict("rejected", last, tuple(flags))


def _assess_success(stderr: str, lines: list[str], summary: Path, flags: list[str]
                    ) -> Verdict:
    """An exit-0 run: degenerate score > printed warning > unexplained null > ok."""
    degenerate = degenerate_reason(summary)
    warned = printed_warnings(stderr)
    data = read_summary(summary)
    nulls = tuple(unexplained_nulls(data)) if isinstance(data, dict) else ()
    flags += [f for f, on in (("degenerate", degenerate), ("warning-printed", warned),
                              ("unexplained-null", nulls)) if on]
    if degenerate:
        return Verdict("degenerate-success", degenerate, tuple(flags), nulls)
    if warned:
        return Verdict("warning-printed", f"{len(warned)} warning line(s), e.g. {warned[0]}",
                       tuple(flags), nulls)
    if nulls:
        shown = ", ".join(nulls[:3]) + (f" (+{len(nulls) - 3} more)" if len(nulls) > 3 else "")
        return Verdict("unexplained-null", f"{len(nulls)} null(s) without a reason: {shown}",
                       tuple(flags), nulls)
    detail = f"{len(lines)} stderr lines, e.g. {explain(stderr)}" if lines else ""
    return Verdict("ok", detail, tuple(flags))


def classify(rc: int | None, stderr: str, written: list[str], summary: Path,
             names: list[str]) -> tuple[str, str]:
    """-> (class, detail) for one finished run (no usage figures: see :func:`assess`)."""
    v = assess(rc, stderr, written, summary, names)
    return v.klass, v.detail


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


__all__ = ["CLASSES", "GOOD", "Limits", "Outcome", "Usage", "Verdict", "assess", "classify",
           "command", "default_slam", "degenerate_reason", "execute", "execute_usage",
           "kill_all", "out_probe", "run_case", "write_case"]
