"""Which kind reads a ``slam run --log`` argument: a bundled log name (resolved through
``gtsam.findExampleDataFile``) or a path, recognised by its first line.

``eqf``: GTSAM's ``EqFdata.csv`` (gyro, direction sensors, truth; the recorded-attitude
kind).  A path whose header is that layout's goes to the same kind; ``kitti``, another
``.csv`` or a folder of the KITTI files is an IMU + GNSS log (the ins-log kind,
:func:`slam.registry.log_kind`); any other path is a planar log in GTSAM's text format
(the recorded-log kind).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from slam.cli_errors import InputError
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
    return log_kind(name), path


def open_recorded(log_file: str, parse_filters: Callable[[Kind], list[str] | None],
                  mode: str | None, holdout: int | None = None,
                  outages: tuple[str, ...] = ()) -> tuple[Any, Kind]:
    """``slam run --log FILE``: the log as a one-run world of the kind that reads it
    (:func:`resolve_log`) and that kind; ``parse_filters(kind)`` the ``--filters`` names
    checked against the kind's.  ``holdout`` and ``outages`` (``START:LENGTH``) apply to
    an IMU + GNSS log only.  Bad input raises :class:`~slam.cli_errors.InputError`."""
    from slam.kinds.ins_log.world import KIND as INS_LOG
    from slam.kinds.recorded.log import LogFormatError
    from slam.registry import open_log
    from worlds import WorldError

    kind, path = resolve_log(log_file)
    if mode is not None and not kind.modes:
        raise InputError(f"--mode {mode}: a {kind.name} log has no filter modes")
    options: dict[str, Any] = {}
    if holdout is not None or outages:
        if kind.name != INS_LOG:
            raise InputError("--holdout and --outage apply to an IMU + GNSS log only "
                             f"(--log kitti or FILE.csv), not to {log_file}")
        from slam.kinds.ins_log.world import parse_outage

        try:
            options = {"holdout": holdout, "outages": [parse_outage(o) for o in outages]}
        except ValueError as exc:
            raise InputError(str(exc)) from None
    try:
        w = open_log(path, parse_filters(kind) or None, mode, kind, **options)
    except (LogFormatError, WorldError) as exc:
        raise InputError(f"--log {exc}") from None
    return w, kind
