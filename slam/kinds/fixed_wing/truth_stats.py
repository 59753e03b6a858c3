"""Facts of the truth flight and the accelerometer's gravity-angle error on it.

The EA filters take roll and pitch from the accelerometer as if it sensed gravity alone
([Fixed-wing EA-UKF] eq. 13).  On the error-free readings of the truth flight the angles
that rule gives differ from the true ones wherever the aircraft accelerates: in a
coordinated turn the specific force stays in the body's x-z plane, so the rule reads the
wings level (roll error about minus the bank angle); a speed change tilts the pitch by
about ``atan(a / g)``.  This is the prediction the measured EA errors are held to.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from nav.euler import q_to_euler_zyx
from slam.kinds.fixed_wing.ea import accel_mag_angles
from slam.kinds.fixed_wing.flight import design
from slam.kinds.fixed_wing.simulate import field_enu, truth_of
from slam.kinds.fixed_wing.world import FixedWingWorld

DEG = math.pi / 180.0


def _rms(x: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(x * x))) if x.size else None


def _max(x: np.ndarray) -> float | None:
    return float(np.max(np.abs(x))) if x.size else None


def segment_masks(world: FixedWingWorld, samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(turn, accelerating)`` at IMU samples ``samples``: the true heading rate above
    ``[scoring] turn_rate_deg_s``; outside turns, the true acceleration above
    ``accel_mps2`` - each anywhere in the EA epoch ending there (the accelerometer angles
    average it).  The rest is steady flight, where the gravity rule is right to
    ``atan(accel_mps2 / g)``."""
    t = np.asarray(samples) * world.imu.dt_s
    span = 1.0 / world.ea.update_rate_hz
    turn = np.zeros(t.shape, dtype=bool)
    accel = np.zeros(t.shape, dtype=bool)
    for back in np.linspace(0.0, span, 5):
        _, a, r = design(world.flight, t - back)
        turn |= np.abs(r) > world.scoring.turn_rate_rad_s
        accel |= np.linalg.norm(a, axis=1) > world.scoring.accel_mps2
    return turn, accel & ~turn


SEGMENTS = ("turns", "accelerating", "steady")


def split(turn: np.ndarray, accel: np.ndarray) -> dict[str, np.ndarray]:
    """The three segment masks by name (:data:`SEGMENTS`)."""
    return {"turns": turn, "accelerating": accel, "steady": ~turn & ~accel}


def flight_facts(world: FixedWingWorld) -> dict[str, Any]:
    """Duration, speed and height range, largest bank and pitch, time in turns."""
    tr = truth_of(world)
    e = q_to_euler_zyx(tr.q) / DEG
    speed = np.linalg.norm(tr.v, axis=1)
    turn = np.abs(tr.turn_rate) > world.scoring.turn_rate_rad_s
    return {"duration_s": tr.n_samples * tr.dt,
            "speed_mps": [float(speed.min()), float(speed.max())],
            "height_m": [float(tr.p[:, 2].min()), float(tr.p[:, 2].max())],
            "max_bank_deg": float(np.max(np.abs(e[:, 0]))),
            "max_abs_pitch_deg": float(np.max(np.abs(e[:, 1]))),
            "turn_time_fraction": float(np.mean(turn)),
            "path_length_m": float(np.sum(speed[:-1]) * tr.dt)}


def accelerometer_angle_errors(world: FixedWingWorld) -> dict[str, Any]:
    """RMS and largest error (deg) of the gravity-rule roll / pitch on error-free
    readings at the EA epochs, per segment (:func:`segment_masks`), with the segment's
    ``epochs`` (the statistics are ``None`` when it is 0)."""
    tr = truth_of(world)
    n = round(world.imu.rate_hz / world.ea.update_rate_hz)
    f = tr.accel.reshape(-1, n, 3).mean(axis=1)
    samples = np.arange(1, f.shape[0] + 1) * n
    q = tr.q[samples]
    from nav.quaternion import qconj, qrotate

    m = qrotate(qconj(q), field_enu(world))
    err = (accel_mag_angles(f, m, field_enu(world)) - q_to_euler_zyx(q))
    err = (err + np.pi) % (2 * np.pi) - np.pi
    err /= DEG
    out: dict[str, Any] = {}
    for seg, mask in split(*segment_masks(world, samples)).items():
        out[seg] = {**{a: {"rms": _rms(err[mask, i]), "max": _max(err[mask, i])}
                       for i, a in enumerate(("roll", "pitch", "heading"))},
                    "epochs": int(np.sum(mask))}
    return out
