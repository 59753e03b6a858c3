"""Interrupts: Ctrl-C exits promptly with 130 and leaves nothing behind; pool workers die
with the campaign's process and are stopped at once when it is interrupted
(:mod:`slam.cli`, :mod:`slam.campaign`).  Two real ``slam`` processes (Linux ``/proc``)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

from slam.campaign import init_worker, stop_pool
from tests.slam.test_cli import SMALL_WORLD

SLAM = Path(sys.executable).with_name("slam")
pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists() or not SLAM.exists(),
                                reason="needs Linux /proc and the slam command")


def _state(pid: int) -> str | None:
    """The process state letter (``None`` when gone)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def _alive(pid: int) -> bool:
    return _state(pid) not in (None, "Z", "X")


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            if int(stat.read_text().rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(stat.parent.name))
        except (OSError, ValueError, IndexError):
            continue
    return out


def _interruptible() -> None:
    """In the child before ``exec``: Ctrl-C's default action, which a shell gives up for the
    jobs it starts in the background (they inherit SIGINT ignored, and Python keeps it so)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _slam(tmp_path: Path, runs: int) -> subprocess.Popen:
    world = tmp_path / "small.toml"
    world.write_text(SMALL_WORLD)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MPLBACKEND="Agg")
    return subprocess.Popen([str(SLAM), "run", str(world), "--runs", str(runs), "--workers",
                             "2", "--no-plots", "--filters", "ekf", "--out",
                             str(tmp_path / "out")], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=_interruptible)


def test_ctrl_c_at_one_second_exits_within_two(tmp_path):
    proc = _slam(tmp_path, runs=20)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    t0 = time.monotonic()
    _, err = proc.communicate(timeout=30)
    assert time.monotonic() - t0 < 2.0
    assert proc.returncode == 130, err.decode()
    assert err.decode().strip().splitlines()[-1] == "error: interrupted"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["small.toml"]  # nothing written


def test_killing_the_parent_leaves_no_live_worker(tmp_path):
    proc = _slam(tmp_path, runs=40)
    deadline = time.monotonic() + 60
    workers: list[int] = []
    while len(workers) < 2 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
        workers = _children(proc.pid)
    assert len(workers) == 2, "the pool never started"
    proc.kill()  # SIGKILL to the parent alone: no chance to clean up
    proc.wait()
    deadline = time.monotonic() + 5.0
    while any(map(_alive, workers)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [w for w in workers if _alive(w)]


def _nap(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def test_stopping_the_pool_does_not_wait_for_runs_in_flight():
    pool = ProcessPoolExecutor(max_workers=2, initializer=init_worker, initargs=(os.getpid(),))
    futures = [pool.submit(_nap, 30.0) for _ in range(4)]
    while not all(f.running() for f in futures[:2]):
        time.sleep(0.01)
    procs = list(pool._processes.values())
    t0 = time.monotonic()
    stop_pool(pool)
    assert time.monotonic() - t0 < 2.0
    # the OS's view (a killed, unreaped worker is a zombie): Process.is_alive() races with
    # the executor's own manager thread reaping the same children
    assert not [p.pid for p in procs if _alive(p.pid)]
