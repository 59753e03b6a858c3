"""The ship simulator (:mod:`slam.kinds.ship.simulate`): the truth meets the stated
conditions, the gyro truth carries the Earth rate, the vector readings have the stated
noise, and a run depends on its seed only."""

from __future__ import annotations

import math

import numpy as np

from nav.quaternion import qconj, qrotate
from nav.spaces import UnitQuaternion
from nav.strapdown import EARTH_RATE, attitudes
from slam.kinds.ship.simulate import simulate_ship
from tests.slam.kinds.ship.worlds import noise_free, ship_world

DEG = math.pi / 180.0


def _period(x: np.ndarray, dt: float) -> float:
    """Mean spacing of upward zero crossings of ``x`` (a sine's period)."""
    up = np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))
    return float(np.mean(np.diff(up))) * dt


def test_the_truth_meets_the_stated_conditions() -> None:
    w = ship_world()
    log = simulate_ship(w, np.random.default_rng(3))
    assert log.times[-1] == 300.0 and log.dt == 0.01 and len(log.gyro) == 30_000
    assert log.n_updates == 301 and np.all(np.diff(log.update_times) == 1.0)
    roll, pitch, yaw = log.euler.T
    yaw = yaw - w.waves.heading_rad
    for x, amp, period in ((roll, 5.0, 8.0), (pitch, 2.0, 6.0), (yaw, 1.0, 10.0)):
        assert abs(np.max(np.abs(x)) / DEG - amp) < 0.02 * amp
        assert abs(_period(x, log.dt) - period) < 0.02 * period
    assert np.allclose(log.truth_bias[0], DEG / 3600.0)  # initial drift 1 deg/h per axis
    lat = 45.0 * DEG
    assert np.allclose(log.earth_rate, EARTH_RATE * np.array([0.0, math.cos(lat),
                                                              math.sin(lat)]))


def test_the_gyro_truth_carries_the_earth_rate() -> None:
    w = ship_world(60.0, **noise_free())
    log = simulate_ship(w, np.random.default_rng(4))
    with_rate = attitudes(log.truth_q[0], log.gyro, log.dt, log.earth_rate)
    quat = UnitQuaternion()
    assert np.max(np.linalg.norm(quat.local(with_rate, log.truth_q), axis=1)) < 1e-11
    without = attitudes(log.truth_q[0], log.gyro, log.dt)
    drift = np.linalg.norm(quat.local(without[-1], log.truth_q[-1]))
    assert abs(drift - EARTH_RATE * 60.0) < 0.02 * EARTH_RATE * 60.0


def test_vector_readings_have_the_stated_noise() -> None:
    w = ship_world()
    log = simulate_ship(w, np.random.default_rng(5))
    assert np.allclose(np.linalg.norm(log.refs, axis=1), 1.0)
    assert math.isclose(log.refs[1, 2], -math.sin(63.0 * DEG))  # field below the horizon
    body = qrotate(qconj(log.update_truth_q)[:, None, :], log.refs[None])
    residual = log.vectors - body  # (M, 2, 3)
    sd = residual.std(axis=(0, 2))
    assert np.allclose(sd, [1e-3, 1e-2], rtol=0.1)
    assert np.abs(residual.mean(axis=(0, 2))).max() < 0.2 * sd.max()


def test_a_run_depends_on_its_seed_only() -> None:
    w = ship_world(20.0)
    a, b = (simulate_ship(w, np.random.default_rng(7)) for _ in range(2))
    c = simulate_ship(w, np.random.default_rng(8))
    assert np.array_equal(a.gyro, b.gyro) and np.array_equal(a.vectors, b.vectors)
    assert not np.array_equal(a.truth_q, c.truth_q) and not np.array_equal(a.gyro, c.gyro)
