"""The drone report's figures built from the shared figure-spec library
(:mod:`slam.render.figures`): the error components of a
:class:`~slam.kinds.drone.scoring.DroneScores` and the specs drawn from them.

    rmse_sigma.png   Monte Carlo RMSE vs RMS own σ: position, velocity, attitude, track
    bias.png         run 0's gyro / accelerometer bias estimates vs truth with ±2σ
    nees.png         position / pose / attitude NEES and NIS vs time in their bands
    landmarks.png    the map over time
    differences.png  each filter minus SRCKF on the same runs
"""

from __future__ import annotations

import math

import numpy as np

from slam.render.consistency import NeesSpec, consistency_figure
from slam.render.figures import (
    FigureSpec,
    Tracked,
    differences_figure,
    estimate_figure,
    map_figure,
    rmse_sigma_figure,
)
from slam.render.series import Component, column

DEG = 180.0 / math.pi
DEG_H = math.pi / 180.0 / 3600.0  # deg/h -> rad/s
MG = 9.80665e-3  # milli-g -> m/s²
_XYZ = ("x", "y", "z")
_RPY = ("roll", "pitch", "yaw")


POSITION = [Component(a, "m", column("err_pos", i), column("sig_pos", i), "position")
            for i, a in enumerate(_XYZ)]
VELOCITY = [Component(a, "m/s", column("err_vel", i), column("sig_vel", i), "velocity")
            for i, a in enumerate(_XYZ)]
ATTITUDE = [Component(a, "deg", column("err_att", i, DEG), column("sig_att", i, DEG))
            for i, a in enumerate(_RPY)]
TRACK = [Component("along-track", "m", column("err_track", 0), column("sig_track", 0)),
         Component("cross-track", "m", column("err_track", 1), column("sig_track", 1)),
         Component("horizontal", "m", lambda s: np.hypot(s.err_pos[:, 0], s.err_pos[:, 1]),
                   lambda s: np.hypot(s.sig_pos[:, 0], s.sig_pos[:, 1]), "position")]


def _bias(kind: str, i: int, axis: str) -> Tracked:
    col, scale, unit = (i, DEG_H, "deg/h") if kind == "gyro" else (3 + i, MG, "mg")
    return Tracked(f"{kind} bias {axis}", unit,
                   lambda tr: tr.bias[:, col] / scale,
                   lambda first: first.truth[:, 10 + col] / scale,
                   lambda s: None if s.sig_bias is None else s.sig_bias[:, col] / scale)


BIASES = [[_bias("gyro", i, a) for i, a in enumerate(_XYZ)],
          [_bias("accelerometer", i, a) for i, a in enumerate(_XYZ)]]

NEES = [NeesSpec("position NEES / 3", 3, lambda s: s.nees_pos),
        NeesSpec("pose NEES / 6", 6, lambda s: s.nees_pose),
        NeesSpec("attitude NEES / 3", 3,
                 lambda s: s.nees_att if s.nees_att is not None else np.full(
                     len(s.nees_pos), np.nan))]


def shared_specs() -> list[FigureSpec]:
    """The drone's figures drawn by the shared builders."""
    return [
        FigureSpec("rmse_sigma.png", "Monte Carlo RMSE (solid) vs the RMS of each "
                   "estimator's own σ (dashed) per epoch: position, velocity, attitude (deg, "
                   "Z-Y-X Euler), and the horizontal error along and across the true "
                   "direction of travel. A consistent filter's two curves coincide; the "
                   "smoother has no velocity σ; IMU only is left out (see drift.png).",
                   rmse_sigma_figure([POSITION, VELOCITY, ATTITUDE, TRACK],
                                     "error vs predicted σ")),
        FigureSpec("bias.png", "Run 0: gyro (deg/h) and accelerometer (mg) bias estimates "
                   "against the truth (black, a random walk from the drawn turn-on bias), "
                   "each filter's ±2σ (thin); the smoother dashed. The y range leaves out "
                   "the first 5 % of the flight.",
                   estimate_figure(BIASES, "sensor bias estimates, run 0")),
        FigureSpec("nees.png", "Position NEES / 3, pose NEES / 6 ([position, body-frame "
                   "attitude]) and attitude NEES / 3 per epoch (run averages) against their "
                   "95 % bands with the fraction of epochs inside, and the filters' NIS / "
                   "dof (grey: its band, which varies with the landmarks seen); right: the "
                   "per-run time averages.", consistency_figure(NEES)),
        FigureSpec("landmarks.png", "The filters' maps per epoch (run averages): RMSE and "
                   "NEES / 3 of the landmarks in the state (against the band), landmarks in "
                   "the state, trace of the map covariance; the smoother's final landmark "
                   "RMSE dashed.", map_figure("the map over time")),
        FigureSpec("differences.png", "Each filter minus the base filter (SRCKF) on the "
                   "same runs (truth cancels): RMS over runs per epoch of the position and "
                   "attitude (Z-Y-X Euler) differences, with the base filter's RMS σ "
                   "(dotted).", differences_figure([POSITION, ATTITUDE],
                                                   "each filter minus {base} on the same "
                                                   "data")),
    ]
