"""A small synthetic IMU + GNSS CSV log with its sidecar (the layout of
:mod:`slam.kinds.ins_log`): a level constant turn, whose body rate and specific force are
constant, so the error-free readings are exact for any time stamps (uneven 5-15 ms here).
Used by the tests and the reader fuzz (:mod:`benchmarks.fuzz.insmutate`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

SIDECAR = """\
[frames]
navigation = "{nav}"
body = "{body}"
[units]
gyro = "{gyro_unit}"
accel = "m/s^2"
[imu]
arw_deg_sqrt_h = 0.05
vrw_mps_sqrt_h = 0.02
gyro_rate_random_walk_deg_h_sqrt_h = 0.5
accel_random_walk_mps2_sqrt_h = 0.001
[gnss]
position_sigma_m = 0.1
[site]
latitude_deg = 45.0
height_m = 0.0
[initial]
velocity_sigma_mps = 0.5
roll_pitch_sigma_deg = 2.0
heading_sigma_deg = 3.0
gyro_bias_sigma_deg_h = 10.0
accel_bias_sigma_mg = 2.0
[alignment]
min_speed_mps = 2.0
[filters]
names = ["ekf", "srckf"]
"""


def turn(t: np.ndarray, speed: float = 10.0, radius: float = 500.0
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """ENU position and velocity, heading, FLU gyro and specific force of the turn at
    times ``t``."""
    from nav.gravity import normal_gravity

    w = speed / radius
    p = np.stack([radius * np.sin(w * t), radius * (1 - np.cos(w * t)), 0 * t], axis=1)
    v = speed * np.stack([np.cos(w * t), np.sin(w * t), 0 * t], axis=1)
    g = float(normal_gravity(math.radians(45.0)))
    gyro = np.tile([0.0, 0.0, w], (len(t), 1))
    accel = np.tile([0.0, speed * w, g], (len(t), 1))
    return p, v, w * t, gyro, accel


def log_text(*, ned: bool = False, deg: bool = False, duration: float = 90.0, seed: int = 0,
             velocity: bool = False, lever_arm: tuple[float, float, float] | None = None
             ) -> tuple[str, str]:
    """The CSV text (uneven 5-15 ms stamps, a fix every second; GNSS velocity columns with
    ``velocity``; the antenna at ``lever_arm`` in the body frame) and its sidecar's."""
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.005, 0.015, int(duration / 0.005))
    t = np.concatenate([[0.0], np.cumsum(steps)])
    t = t[t <= duration]
    t = np.union1d(t, np.arange(0.0, duration))  # a row at every whole second
    p, v, yaw, gyro, accel = turn(t)
    truth = p
    if lever_arm is not None:
        c, s = np.cos(yaw), np.sin(yaw)
        la = np.asarray(lever_arm, dtype=float)
        p = p + np.stack([c * la[0] - s * la[1], s * la[0] + c * la[1], la[2] + 0 * t], 1)
    if ned:
        p, v, truth = (np.stack([a[:, 1], a[:, 0], -a[:, 2]], axis=1) for a in (p, v, truth))
        gyro = gyro * [1, -1, -1]
        accel = accel * [1, -1, -1]
    if deg:
        gyro = np.degrees(gyro)
    fix = np.isin(t, np.arange(0.0, duration))
    head = "t,gx,gy,gz,ax,ay,az,px,py,pz" + (",vx,vy,vz" if velocity else "") + ",tx,ty,tz"
    lines = [head]
    def cells(a: np.ndarray, k: int) -> str:
        return ",".join(f"{x:.9f}" for x in a[k]) if fix[k] else ",,"

    for k in range(len(t)):
        row = [f"{t[k]:.9f}", ",".join(f"{x:.12g}" for x in (*gyro[k], *accel[k])),
               cells(p, k)]
        if velocity:
            row.append(cells(v, k))
        row.append(cells(truth, k))
        lines.append(",".join(row))
    side = SIDECAR.format(nav="NED" if ned else "ENU", body="FRD" if ned else "FLU",
                          gyro_unit="deg/s" if deg else "rad/s")
    if velocity:
        side = side.replace("position_sigma_m = 0.1\n",
                            "position_sigma_m = 0.1\nvelocity_sigma_mps = 0.05\n")
    if lever_arm is not None:
        side = side.replace("position_sigma_m = 0.1\n",
                            f"position_sigma_m = 0.1\nlever_arm_m = {list(lever_arm)}\n")
    return "\n".join(lines) + "\n", side


def write_log(folder: Path, name: str = "turn", **options: object) -> Path:
    """:func:`log_text` (``options``) written as ``folder/name.csv`` and ``folder/name.toml``."""
    csv, side = log_text(**options)  # type: ignore[arg-type]
    path = folder / f"{name}.csv"
    path.write_text(csv, encoding="utf-8")
    path.with_suffix(".toml").write_text(side, encoding="utf-8")
    return path
