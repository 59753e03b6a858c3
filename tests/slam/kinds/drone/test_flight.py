"""The drone's truth simulator (:mod:`slam.kinds.drone.flight`): steering through the
waypoints, flight over hills, and the truth as the mechanisation of its own readings.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nav.euler import q_to_euler_zyx
from nav.strapdown import (
    gravity_enu,
    mechanise,
)
from nav.terrain import Terrain
from slam.kinds.drone.flight import FlightPlan, fly, steer

G = gravity_enu()


def plan(**kw) -> FlightPlan:
    base = dict(waypoints=((30.0, 0.0), (30.0, 30.0), (0.0, 30.0), (0.0, 0.0)),
                start_xy=(0.0, 0.0), start_heading=0.0, speed=3.0,
                max_turn_rate=math.radians(25.0), max_turn_accel=math.radians(30.0),
                steer_gain=1.5, at_waypoint=1.0, loops=1, height_above_ground=5.0,
                altitude_smoothing_s=1.0, dt=0.01, drag_per_s=0.3)
    base.update(kw)
    return FlightPlan(**base)


def test_steering_reaches_every_waypoint_with_bounded_turn_rate_and_accel():
    pl = plan(loops=2)
    xy, psi, rate, ends = steer(pl)
    assert len(ends) == 2 and ends[-1] == len(xy) - 1
    assert np.hypot(*(xy[-1] - pl.waypoints[-1])) < pl.at_waypoint
    assert np.max(np.abs(rate)) <= pl.max_turn_rate + 1e-12
    assert np.max(np.abs(np.diff(rate))) <= pl.max_turn_accel * pl.dt + 1e-12
    with pytest.raises(ValueError, match="not reached"):
        steer(plan(waypoints=((0.5, 0.2), (30.0, 0.0))), max_duration_s=5.0)


def test_flight_over_hills_keeps_height_and_bounded_acceleration():
    ter = Terrain.hills((-20.0, 50.0, -20.0, 50.0), [[15.0, 0.0], [30.0, 15.0]], 5.0, 6.0,
                        spacing=1.0)
    tr = fly(plan(), ter.height, G)
    agl = tr.p[:, 2] - ter.height(tr.p[:, :2])
    assert abs(np.mean(agl) - 5.0) < 0.3 and np.min(agl) > 3.5
    acc = np.diff(tr.v, axis=0) / tr.dt
    assert np.max(np.linalg.norm(acc, axis=1)) < 3.0
    # multirotor attitude: nose-down against the drag, banked in the turns
    e = np.degrees(q_to_euler_zyx(tr.q))
    assert 3.0 < np.median(e[:, 1]) < 8.0 and np.max(np.abs(e[:, 0])) > 3.0
    # the truth IS the mechanisation of the error-free readings
    P, V, Q = mechanise(tr.p[:1], tr.v[:1], tr.q[:1], tr.gyro, tr.accel, tr.dt, G)
    assert np.allclose(P[0], tr.p[-1], atol=1e-9) and np.allclose(V[0], tr.v[-1], atol=1e-10)
