"""The alignment simulator: the truth meets the paper's sway and eq. 13 numbers, the
mechanisation at rest reproduces the Earth rate and gravity, the fast quaternion helpers
equal the library's, and the Markov errors have their stated size."""

from __future__ import annotations

import math

import numpy as np

from nav.euler import euler_zyx_to_q, q_to_euler_zyx
from nav.quaternion import qconj, qmul, qrotate, skew
from nav.strapdown import EARTH_RATE, G0, hamilton
from slam.kinds.alignment.simulate import (
    markov,
    simulate_alignment,
    sway_attitude,
    wind_velocity,
)
from tests.slam.kinds.alignment.worlds import CALM, NO_ERRORS, STILL, alignment_world


def test_sway_and_wind_meet_the_paper_numbers() -> None:
    world = alignment_world(2.0)
    t = np.arange(0.0, 2.0, 1e-3)
    e = q_to_euler_zyx(sway_attitude(world, t, np.zeros(2)))
    elev, roll = np.degrees(-e[:, 1]), np.degrees(e[:, 0])
    assert abs(elev.max() - 50.0) < 0.01 and abs(elev.min() - 40.0) < 0.01
    assert abs(roll.max() - 3.0) < 0.01 and abs(roll.min() + 3.0) < 0.01
    assert np.allclose(np.degrees(e[:, 2]), 30.0)
    # 2 Hz elevation and 10 Hz roll: upward zero crossings of the deviation per second
    for dev, hz in ((elev - 45.0, 2.0), (roll, 10.0)):
        ups = np.sum((dev[:-1] < 0) & (dev[1:] >= 0))
        assert abs(ups / 2.0 - hz) <= 0.5
    # wind: velocity = c dw/dt of eq. 13; the 0.25 Hz term's amplitude 0.5 and 0.3 m/s
    v = wind_velocity(world, np.array([0.0]))
    c = world.wind.compliance_m_per_mps
    ex = c * 2 * math.pi * (1.0 * 0.15 + 0.5 * 0.2 * math.cos(0.5) + 0.25 * 0.5)
    ey = c * 2 * math.pi * (1.0 * 0.15 + 0.5 * 0.2 * math.cos(0.5) + 0.25 * 0.3)
    assert np.allclose(v[0], [ex, ey, 0.0], rtol=1e-12)


def test_mechanisation_at_rest_reproduces_earth_rate_and_gravity() -> None:
    world = alignment_world(3.0, **NO_ERRORS, **CALM, **STILL,
                            **{"filters.initial_misalignment_deg": [0.0, 0.0, 0.0]})
    log = simulate_alignment(world, np.random.default_rng(0))
    q = log.truth_q[0]
    lat = world.site.latitude_rad
    wie = EARTH_RATE * np.array([0.0, math.cos(lat), math.sin(lat)])
    assert np.allclose(log.gyro, qrotate(qconj(q), wie), atol=1e-12, rtol=0)
    assert np.allclose(log.accel, qrotate(qconj(q), [0.0, 0.0, G0]), atol=1e-10, rtol=0)
    assert np.max(np.abs(log.sins_v)) < 1e-9
    assert np.max(np.abs(log.sins_q - log.truth_q)) < 1e-12


def test_noise_free_sins_follows_the_swaying_truth() -> None:
    world = alignment_world(3.0, **NO_ERRORS, **{"filters.initial_misalignment_deg":
                                                  [0.0, 0.0, 0.0]})
    log = simulate_alignment(world, np.random.default_rng(1))
    assert np.max(np.abs(log.sins_q - log.truth_q)) < 1e-11
    # the SINS starts at the zero reference, the launcher with the wind's velocity: that
    # offset only turns with the Coriolis term, dV_{j+1} = (I - 2T[w]x) dV_j
    F = np.eye(3) - 2.0 * log.T * skew(log.earth_rate)
    dv = [log.sins_v[0] - log.truth_v[0]]
    for _ in range(log.n_epochs - 1):
        dv.append(F @ dv[-1])
    # (the Earth's turn inside each 0.1 s interval is first order: ~3e-11 m/s per interval)
    assert np.max(np.abs(log.sins_v - log.truth_v - np.array(dv))) < 1e-9


def test_fast_helpers_equal_the_library() -> None:
    rng = np.random.default_rng(3)
    p, q = rng.standard_normal((2, 50, 4))
    assert np.allclose(hamilton(p, q), qmul(p, q), atol=1e-15)
    world = alignment_world(1.0)
    t = rng.uniform(0, 1, 20)
    s = world.sway
    elev = s.elevation_rad + s.elevation_amplitude_rad * np.sin(2 * np.pi * 2.0 * t)
    roll = s.roll_amplitude_rad * np.sin(2 * np.pi * 10.0 * t)
    assert np.allclose(sway_attitude(world, t, np.zeros(2)),
                       euler_zyx_to_q(roll, -elev, np.full_like(t, s.heading_rad)), atol=1e-15)


def test_markov_is_stationary_with_its_sigma() -> None:
    m = markov(20_000, 2.0, 50.0, 1.0, np.random.default_rng(5))
    lag = np.mean(m[1:] * m[:-1]) / np.mean(m * m)
    assert abs(np.std(m) - 2.0) < 0.3 and abs(lag - math.exp(-1 / 50.0)) < 0.01
