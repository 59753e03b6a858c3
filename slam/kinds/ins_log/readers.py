"""The KITTI and CSV readers (:mod:`slam.kinds.ins_log.log` for the files' layouts)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from nav.strapdown import G0
from slam.kinds.ins_log.log import (
    KITTI_FILES,
    InsLog,
    check_times,
    in_range_fixes,
    number,
    read_lines,
)
from slam.kinds.ins_log.settings import KITTI_METADATA, kitti_settings, read_sidecar
from slam.kinds.recorded.log import LogFormatError

#: Fewest readings and fixes a log must hold.
MIN_READINGS, MIN_FIXES = 2, 3
CSV_REQUIRED = ("t", "gx", "gy", "gz", "ax", "ay", "az")
CSV_OPTIONAL = ("px", "py", "pz", "vx", "vy", "vz", "sp", "sv", "tx", "ty", "tz")

__all__ = ["bundled_kitti", "read_csv", "read_kitti"]


def bundled_kitti() -> Path:
    """The folder of GTSAM's KITTI files (``gtsam.findExampleDataFile``)."""
    import gtsam

    try:
        return Path(gtsam.findExampleDataFile(KITTI_FILES[0])).parent
    except (RuntimeError, IndexError, ValueError) as exc:
        raise LogFormatError("kitti", None, f"the gtsam wheel has no {KITTI_FILES[0]} "
                             f"({exc})") from None


def _rows(path: Path, sep: str | None, width: int, names: tuple[str, ...]
          ) -> tuple[np.ndarray, list[int]]:
    """Data rows after a one-line header: ``width`` numbers each."""
    source = str(path)
    lines = read_lines(path)
    if not lines:
        raise LogFormatError(source, None, "empty file")
    out, where = [], []
    for i, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        parts = line.split(sep) if sep else line.split()
        if len(parts) != width:
            raise LogFormatError(source, i, f"{len(parts)} fields, expected {width} "
                                 f"({' '.join(names)})")
        out.append([number(p, source, i, names[j]) for j, p in enumerate(parts)])
        where.append(i)
    if not out:
        raise LogFormatError(source, None, "no data rows after the header")
    return np.asarray(out, dtype=np.float64), where


def read_kitti(folder: Path, filters: tuple[str, ...] | None = None) -> InsLog:
    """GTSAM's KITTI IMU, GPS and metadata files in ``folder``."""
    imu_p, gps_p, meta_p = (folder / f for f in KITTI_FILES)
    meta_rows, _ = _rows(meta_p, None, len(KITTI_METADATA), KITTI_METADATA)
    meta = dict(zip(KITTI_METADATA, meta_rows[0].tolist()))
    for key in KITTI_METADATA[6:]:
        if meta[key] < 0.0 or (key != "IntegrationSigma" and meta[key] == 0.0):
            raise LogFormatError(str(meta_p), 2, f"{key} = {meta[key]!r}: must be > 0")
    if meta["AverageDeltaT"] > 10.0 or meta["GyroscopeSigma"] > 10 or meta[
            "AccelerometerSigma"] > 100:
        raise LogFormatError(str(meta_p), 2, "AverageDeltaT <= 10 s, GyroscopeSigma <= 10, "
                             "AccelerometerSigma <= 100 required")
    if any(abs(meta[k]) > 1e-12 for k in KITTI_METADATA[3:6]):
        raise LogFormatError(str(meta_p), 2, "BodyPrx/BodyPry/BodyPrz must be 0 (a rotated "
                             "IMU mounting is not supported)")
    if any(abs(meta[k]) > 100.0 for k in KITTI_METADATA[:3]):
        raise LogFormatError(str(meta_p), 2, "BodyPt* (lever arm) must be within 100 m")
    imu, imu_lines = _rows(imu_p, None, 8, ("time", "dt", "accelX", "accelY", "accelZ",
                                            "omegaX", "omegaY", "omegaZ"))
    gps, gps_lines = _rows(gps_p, ",", 4, ("Time", "X", "Y", "Z"))
    t = imu[:, 0]
    check_times(t, str(imu_p), imu_lines, "IMU")
    # the dt column is the time since the previous row (the first row's is its stamp):
    # the stamps alone drive the model, the column is checked against them
    bad = np.flatnonzero(np.abs(imu[1:, 1] - np.diff(t)) > 1e-6 * np.maximum(1.0, imu[1:, 1]))
    if len(bad):
        k = int(bad[0]) + 1
        raise LogFormatError(str(imu_p), imu_lines[k], f"dt = {imu[k, 1]!r} is not the time "
                             f"since the previous row ({t[k] - t[k - 1]!r})")
    check_times(gps[:, 0], str(gps_p), gps_lines, "GPS")
    settings = kitti_settings(meta, filters)
    sp = np.full((len(gps), 3), settings.position_sigma_m)
    return _finish(t, imu[:, 5:8], imu[:, 2:5], gps[:, 0], gps[:, 1:4], None, sp, None,
                   settings, "kitti" if folder == _safe_bundled() else str(folder), "kitti")


def _safe_bundled() -> Path | None:
    try:
        return bundled_kitti()
    except LogFormatError:
        return None


def _finish(t, gyro, accel, fix_t, fix_p, fix_v, fix_sp, fix_sv, settings, source, name,
            truth_p=None) -> InsLog:
    """Bounds checks, the fixes inside the readings' span, and the log value."""
    if len(t) < MIN_READINGS:
        raise LogFormatError(source, None, f"{len(t)} IMU readings: at least {MIN_READINGS}")
    if np.any(np.abs(gyro) > 1e3) or np.any(np.abs(accel) > 1e4):
        raise LogFormatError(source, None, "IMU readings beyond 1000 rad/s or 10000 m/s^2")
    if (fix_p is not None and np.any(np.abs(fix_p) > 1e8)) or (
            fix_v is not None and np.any(np.abs(fix_v) > 1e5)):
        raise LogFormatError(source, None, "GNSS fixes beyond 1e8 m or 1e5 m/s")
    keep = in_range_fixes(t, fix_t)
    sel = (lambda a: None if a is None else a[keep])  # noqa: E731
    if keep.sum() < MIN_FIXES:
        raise LogFormatError(source, None, f"{int(keep.sum())} GNSS fixes inside the IMU "
                             f"time span: at least {MIN_FIXES}")
    if t[-1] - t[0] > 1e6:
        raise LogFormatError(source, None, "longer than 1e6 s")
    if truth_p is not None and np.any(np.abs(truth_p[np.isfinite(truth_p)]) > 1e8):
        raise LogFormatError(source, None, "truth positions beyond 1e8 m")
    return InsLog(t, gyro, accel, fix_t[keep], sel(fix_p), sel(fix_v), sel(fix_sp),
                  sel(fix_sv), settings, source, name, int((~keep).sum()),
                  truth_p=sel(truth_p))


def _to_enu_flu(v: np.ndarray, frame: str) -> np.ndarray:
    """NED -> ENU / FRD -> FLU (``[y, x, -z]`` and ``[x, -y, -z]``); ENU/FLU unchanged."""
    if frame == "NED":
        return np.stack([v[:, 1], v[:, 0], -v[:, 2]], axis=1)
    if frame == "FRD":
        return np.stack([v[:, 0], -v[:, 1], -v[:, 2]], axis=1)
    return v


def read_csv(path: Path, filters: tuple[str, ...] | None = None) -> InsLog:
    """A CSV log and its sidecar (:mod:`slam.kinds.ins_log`)."""
    source = str(path)
    lines = read_lines(path)
    settings = read_sidecar(path.with_suffix(".toml"), filters)
    body = [(i, ln) for i, ln in enumerate(lines, start=1)
            if ln.strip() and not ln.lstrip().startswith("#")]
    if not body:
        raise LogFormatError(source, None, "empty file (a header line and rows expected)")
    head_line, head = body[0]
    cols = [c.strip() for c in head.split(",")]
    unknown = [c for c in cols if c not in CSV_REQUIRED + CSV_OPTIONAL]
    if unknown or len(set(cols)) != len(cols):
        what = f"unknown column {unknown[0]!r}" if unknown else "a column repeats"
        raise LogFormatError(source, head_line, f"{what}; columns: {', '.join(CSV_REQUIRED)} "
                             f"(required), {', '.join(CSV_OPTIONAL)} (optional)")
    missing = [c for c in CSV_REQUIRED if c not in cols]
    for group in (("px", "py", "pz"), ("vx", "vy", "vz"), ("tx", "ty", "tz")):
        if any(c in cols for c in group) and not all(c in cols for c in group):
            missing.append("/".join(group))
    if missing:
        raise LogFormatError(source, head_line, f"missing column {missing[0]}")
    if "px" not in cols:
        raise LogFormatError(source, head_line, "no GNSS position columns px,py,pz (required; "
                             "vx,vy,vz optional)")
    if "vx" in cols and settings.velocity_sigma_mps is None and "sv" not in cols:
        raise LogFormatError(source, None, "velocity columns need [gnss] velocity_sigma_mps "
                             "in the sidecar or an sv column")
    idx = {c: j for j, c in enumerate(cols)}
    n = len(cols)
    data = np.full((len(body) - 1, n), np.nan)
    where = []
    for r, (i, ln) in enumerate(body[1:]):
        parts = ln.split(",")
        if len(parts) != n:
            raise LogFormatError(source, i, f"{len(parts)} fields, expected {n}")
        for c, j in idx.items():
            tok = parts[j].strip()
            if tok == "" and c not in CSV_REQUIRED:
                continue
            data[r, j] = number(tok, source, i, c)
        where.append(i)
    if not where:
        raise LogFormatError(source, None, "no data rows after the header")
    t = data[:, idx["t"]]
    check_times(t, source, where, "row")
    gyro = data[:, [idx["gx"], idx["gy"], idx["gz"]]]
    accel = data[:, [idx["ax"], idx["ay"], idx["az"]]]
    if settings.gyro_unit == "deg/s":
        gyro = np.radians(gyro)
    if settings.accel_unit == "g":
        accel = accel * G0
    gyro, accel = _to_enu_flu(gyro, settings.body), _to_enu_flu(accel, settings.body)

    def block(names: tuple[str, str, str]) -> np.ndarray | None:
        return data[:, [idx[c] for c in names]] if names[0] in idx else None

    pos, vel = block(("px", "py", "pz")), block(("vx", "vy", "vz"))
    truth = block(("tx", "ty", "tz"))
    if truth is not None:
        partial = np.flatnonzero(np.isfinite(truth).any(axis=1) & ~np.isfinite(truth).all(axis=1))
        if len(partial):
            raise LogFormatError(source, where[int(partial[0])], "tx,ty,tz: all three or none")
    has = np.zeros(len(t), dtype=bool)
    for b, name in ((pos, "px,py,pz"), (vel, "vx,vy,vz")):
        if b is None:
            continue
        filled = np.isfinite(b)
        partial = np.flatnonzero(filled.any(axis=1) & ~filled.all(axis=1))
        if len(partial):
            raise LogFormatError(source, where[int(partial[0])], f"{name}: all three or none")
        has |= filled.all(axis=1)
    if pos is not None and vel is not None:
        both = np.isfinite(pos).all(axis=1) == np.isfinite(vel).all(axis=1)
        if not both.all():
            k = int(np.flatnonzero(~both)[0])
            raise LogFormatError(source, where[k], "a fix with a position must have a velocity "
                                 "and the reverse (both column groups are present)")
    rows = np.flatnonzero(has)
    fix_p = None if pos is None else _to_enu_flu(pos[rows], settings.navigation)
    fix_v = None if vel is None else _to_enu_flu(vel[rows], settings.navigation)

    def sigma(col: str, default: float | None) -> np.ndarray | None:
        if col in idx:
            s = data[rows, idx[col]]
            bad = np.flatnonzero(~(s > 0) & np.isfinite(s))
            if len(bad):
                raise LogFormatError(source, where[int(rows[bad[0]])], f"{col} must be > 0")
            if default is None and np.any(~np.isfinite(s)):
                raise LogFormatError(source, where[int(rows[np.flatnonzero(~np.isfinite(s))[0]])],
                                     f"{col} is empty and the sidecar states no default")
            s = np.where(np.isfinite(s), s, default if default is not None else math.nan)
        elif default is None:
            return None
        else:
            s = np.full(len(rows), default)
        return np.repeat(s[:, None], 3, axis=1)

    sp = sigma("sp", settings.position_sigma_m) if pos is not None else None
    sv = sigma("sv", settings.velocity_sigma_mps) if vel is not None else None
    tp = None if truth is None else _to_enu_flu(truth[rows], settings.navigation)
    return _finish(t, gyro, accel, t[rows], fix_p, fix_v, sp, sv, settings, source, path.stem,
                   tp)
