"""Stated limits on what one run may cost, checked before anything runs.

Every key of a world file has its own allowed range, but values inside their ranges can
still multiply into a run that never ends or exhausts memory (a speed of 1e-300 m/s, a
gyro at 10 kHz for a day).  The kinds therefore check the *derived* sizes of a run
against these limits when a world is validated, and a world beyond one is refused like
any other bad value: a :class:`~worlds.schema.WorldError` naming the key, the derived
size and the limit.  The limits leave a wide margin around the bundled worlds (the
largest bundled values are quoted in brackets).

=========================  =============================================================
``MAX_SAMPLES``            control steps / IMU samples / gyro samples of one run (30 000)
``MAX_EPOCHS``             filter epochs (sensor scans, star updates) of one run (2 200)
``MAX_STATE``              state dimension if every landmark near the path is mapped (273)
``MAX_WORK``               filter work of one run: epochs x (state + noise inputs)^3 in
                           joint mode, (vehicle + noise inputs)^3 + 10 state^2 in local
                           mode (5e10, densemap)
``MAX_TERRAIN_VERTICES``   vertices of a gridded terrain (9 500)
``MAX_FILE_BYTES``         a world, map, mesh or log file (victoria_park.txt: 0.4 MB)
``MAX_NESTING``            nesting depth of TOML/JSON values, and parts of a dotted TOML
                           key, checked before parsing (3)
``MIN_VARIANCE``           smallest non-zero noise variance in SI units (bundled: 1e-23)
=========================  =============================================================

Every kind declares what one run of a world costs (``Kind.work``): :class:`Size` values
for its samples, filter epochs, state dimension and filter work, each naming the world
key that drives it.  The registry checks them here, in one place (:func:`check_work`),
after the world's keys are checked and before anything is simulated or allocated.
"""

from __future__ import annotations

import math
import os
import stat
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from typing import Any

import numpy as np

MAX_SAMPLES = 250_000
MAX_EPOCHS = 50_000
MAX_STATE = 3_000
MAX_WORK = 2e11
MAX_TERRAIN_VERTICES = 4_000_000
MAX_FILE_BYTES = 64 << 20
MAX_NESTING = 32
MIN_VARIANCE = 1e-200


def count(n: float) -> str:
    """A derived size for a message: ``"3.2e+08"`` or ``"12,000"``."""
    if not math.isfinite(n):
        return "unbounded"
    return f"{n:,.0f}" if n < 1e7 else f"{n:.2g}"


def over(what: str, n: float, limit: float, why: str = "") -> str | None:
    """The message for a derived size ``n`` above ``limit`` (``None`` when within)."""
    if n <= limit:
        return None
    why = f" ({why})" if why else ""
    return f"the run would need {count(n)} {what}{why}; at most {count(limit)} are allowed"


BOUNDS = ("samples", "epochs", "state", "work")
"""The sizes every kind's work must state (:func:`check_work`); a kind may state more
(``"vertices"``: a gridded terrain)."""


def limit_of(bound: str) -> float:
    """The limit of a size of kind ``bound`` (read when checked: one place to change)."""
    return {"samples": MAX_SAMPLES, "epochs": MAX_EPOCHS, "state": MAX_STATE,
            "work": MAX_WORK, "vertices": MAX_TERRAIN_VERTICES}[bound]


@dataclass(frozen=True)
class Size:
    """One derived size of a run: ``n`` ``what`` (``"gyro samples"``) counted against the
    limit of ``bound`` (one of :data:`BOUNDS` or ``"vertices"``), driven by the dotted
    world key ``key`` (``None``: the input file as a whole, e.g. a recorded log); ``why``
    says how ``n`` follows from the world's numbers."""

    bound: str
    what: str
    n: float
    key: str | None
    why: str = ""

    def message(self) -> str | None:
        """The refusal when ``n`` is over its limit, else ``None``."""
        return over(self.what, self.n, limit_of(self.bound), self.why)


def check_work(sizes: Iterable[Size], kind: str,
               error: Callable[[Size, str], Exception]) -> None:
    """Raise ``error(size, message)`` for the first of ``sizes`` over its limit.

    ``sizes`` is read in order and may be a generator, so a kind states its cheap sizes
    first and computes a costly one (landmarks near a long path) only once the sizes
    before it are within their limits.  A kind whose work leaves out one of
    :data:`BOUNDS` is a programming error (``TypeError``), not a bad world.
    """
    seen = set()
    for size in sizes:
        if size.bound not in (*BOUNDS, "vertices"):
            raise TypeError(f"kind {kind!r}: unknown work bound {size.bound!r}")
        if msg := size.message():
            raise error(size, msg)
        seen.add(size.bound)
    if missing := [b for b in BOUNDS if b not in seen]:
        raise TypeError(f"kind {kind!r}: its work states no {', '.join(missing)}")


def filter_work(epochs: float, samples: float, state: int, noise: int) -> float:
    """Units of filter work of a run with a dense state: ``epochs × (state + noise)³``
    (the factorisations of one predict/update cycle) plus ``samples × (2 (state +
    noise) + 1) × state`` (every point through every sample of a batched transition)."""
    width = state + noise
    return epochs * width**3 + samples * (2 * width + 1) * state


def check_file(target: Traversable, error: Callable[[str], Exception],
               limit: int = MAX_FILE_BYTES) -> None:
    """Raise ``error(reason)`` unless ``target`` is a regular file of at most ``limit``
    bytes (no device, fifo or folder: ``/dev/zero`` would be read for ever)."""
    if isinstance(target, os.PathLike):
        try:
            st = os.stat(target)
        except FileNotFoundError:
            raise error("file not found") from None
        except OSError as exc:
            raise error(f"cannot read ({exc.strerror or exc})") from None
        except ValueError:  # a NUL character in the path
            raise error("is not a valid file name") from None
        if not stat.S_ISREG(st.st_mode):
            raise error("is not a regular file")
        size = st.st_size
    else:  # a packaged resource
        if not target.is_file():
            raise error("file not found")
        size = len(target.read_bytes())
    if size > limit:
        raise error(f"is {count(size)} bytes; at most {count(limit)} are allowed")


def depth(value: Any, limit: int = MAX_NESTING) -> int:
    """Nesting depth of lists and tables in ``value`` (iterative; stops past ``limit``)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict | list):
            deepest = max(deepest, d + 1)
            if deepest > limit:
                return deepest
            stack.extend((x, d + 1) for x in (v.values() if isinstance(v, dict) else v))
    return deepest


def path_length(start: tuple[float, float], waypoints: np.ndarray, loops: int) -> float:
    """Length of the waypoint polyline flown: start to the first waypoint, then ``loops``
    laps through the waypoints and back to the first."""
    wps = np.asarray(waypoints, dtype=float).reshape(-1, 2)
    lap = np.vstack([wps, wps[:1]])
    first = math.dist(start, wps[0])
    return first + loops * float(np.hypot(*np.diff(lap, axis=0).T).sum())


def near_path(points: np.ndarray, start: tuple[float, float], waypoints: np.ndarray,
              reach: float) -> int:
    """How many ``points`` lie within ``reach`` of the flown polyline (the landmarks a
    sensor of that range could ever see, turns aside)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    wps = np.asarray(waypoints, dtype=float).reshape(-1, 2)
    poly = np.vstack([np.asarray(start, float)[None], wps, wps[:1]])
    a, b = poly[:-1], poly[1:]
    ab = b - a
    ab2 = np.maximum(np.sum(ab * ab, axis=1), 1e-300)
    near = np.zeros(len(pts), dtype=bool)
    rows = max(1, 2_000_000 // len(a))
    for s in range(0, len(pts), rows):  # (rows, segments) at a time
        p = pts[s:s + rows, None, :]
        t = np.clip(np.sum((p - a) * ab, axis=2) / ab2, 0.0, 1.0)
        d = np.hypot(*(p - (a + t[..., None] * ab)).transpose(2, 0, 1))
        near[s:s + rows] = (d <= reach).any(axis=1)
    return int(near.sum())
