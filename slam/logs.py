"""Which kind reads a ``slam run --log`` argument: a bundled log name (resolved through
``gtsam.findExampleDataFile``) or a path, recognised by its first line.

``eqf``: GTSAM's ``EqFdata.csv`` (gyro, direction sensors, truth; the recorded-attitude
kind).  A path whose header is that layout's goes to the same kind; any other path is a
planar log in GTSAM's text format (the recorded-log kind).
"""

from __future__ import annotations

from pathlib import Path

from slam.kind import Kind

BUNDLED_LOGS: dict[str, tuple[str, str]] = {"eqf": ("recorded-attitude", "EqFdata.csv")}
"""``--log NAME`` -> (kind, the gtsam example file)."""


def resolve_log(name: str) -> tuple[Kind, Path]:
    """The kind that reads ``--log name`` and the file it reads (an existing file of
    that name wins over a bundled name)."""
    from slam.kinds.attitude_log.log import is_attitude_log
    from slam.registry import get_kind, log_kind

    path = Path(name)
    if name in BUNDLED_LOGS and not path.exists():
        import gtsam

        kind, file = BUNDLED_LOGS[name]
        return get_kind(kind), Path(gtsam.findExampleDataFile(file))
    if is_attitude_log(path):
        return get_kind("recorded-attitude"), path
    return log_kind(), path
