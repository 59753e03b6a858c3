"""Fixed-wing filters and smoother on small logs: noise-free logs are tracked to round-off
by every filter, the EA filters' gravity-from-accelerometer error appears in turns, the
GTSAM smoother's marginals pass a χ² NEES test, and a numerical failure is a counted
divergence."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nav.euler import q_to_euler_zyx
from slam.kinds.fixed_wing import run as fr
from slam.kinds.fixed_wing.simulate import simulate
from slam.kinds.fixed_wing.world import EA_FILTERS, INS_FILTERS
from slam.results import REFERENCE
from slam.scoring import anees_band
from tests.slam.kinds.fixed_wing.worlds import LEVEL_FLIGHT, NOISE_FREE, short_world

DEG = math.pi / 180.0
TINY = {"gnss.horizontal_sigma_m": 1e-6, "gnss.vertical_sigma_m": 1e-6,
        "gnss.velocity_sigma_mps": 1e-6, "ea.roll_pitch_sigma_deg": 1e-6,
        "ea.heading_sigma_deg": 1e-6}


def _exact_priors(log):
    tr = log.traj
    x_ins = np.concatenate([tr.p[0], tr.v[0], tr.q[0], np.zeros(9)])
    x_ea = np.concatenate([q_to_euler_zyx(tr.q[0]), np.zeros(3)])
    return (x_ins, np.eye(18) * 1e-14), (x_ea, np.eye(6) * 1e-14)


@pytest.mark.parametrize("name", [f"ins-{n}" for n in INS_FILTERS])
def test_ins_filters_track_a_noise_free_log_to_round_off(name) -> None:
    w = short_world(**NOISE_FREE, **TINY)
    log = simulate(w, np.random.default_rng(0), scale=0.0)
    (x0, P0), _ = _exact_priors(log)
    s = fr.run_ins(log, name, x0, P0)
    assert not s.diverged, s.failure
    assert np.max(np.abs(s.err_pos)) < 1e-6 and np.max(np.abs(s.err_vel)) < 1e-7
    assert np.max(np.abs(s.err_att)) < 1e-9


@pytest.mark.parametrize("name", [f"ea-{n}" for n in EA_FILTERS])
def test_ea_filters_track_a_noise_free_level_flight_to_round_off(name) -> None:
    w = short_world(**NOISE_FREE, **TINY, **LEVEL_FLIGHT, duration_s=10.0)
    log = simulate(w, np.random.default_rng(0), scale=0.0)
    _, (x0, P0) = _exact_priors(log)
    s = fr.run_ea(log, name, x0, P0)
    assert not s.diverged, s.failure
    assert np.max(np.abs(s.err_att)) < 1e-9


def test_ea_roll_error_comes_from_the_gravity_rule_in_the_turn() -> None:
    """Error-free sensors, a coordinated turn from 15 s: the accelerometer angles read the
    wings level (error = minus the bank), and the EA filter's roll error grows with it."""
    w = short_world()
    log = simulate(w, np.random.default_rng(0), scale=0.0)
    _, z = fr.ea_observations(log)
    bank = q_to_euler_zyx(log.traj.q[::log.n_ea])[:, 0]
    t = np.arange(len(bank)) * log.n_ea * log.dt
    turn, before = t > 20.0, (t > 1.0) & (t < 4.9)
    assert np.max(np.abs(bank[turn])) > 15 * DEG
    assert np.allclose(z[turn, 0] - bank[turn], -bank[turn], atol=0.5 * DEG)
    assert np.max(np.abs(z[before] - q_to_euler_zyx(log.traj.q[::log.n_ea])[before])) < 1e-9
    _, (x0, P0) = _exact_priors(log)
    s = fr.run_ea(log, "ea-ckf", x0, np.diag([DEG, DEG, DEG, 1e-5, 1e-5, 1e-5]) ** 2)
    err = np.abs(s.err_att[:, 0])
    assert err[turn].mean() > 2 * DEG and err[turn].mean() > 20 * err[before].mean()


def test_smoother_marginals_pass_a_chi2_nees_test() -> None:
    """Matched bias model (Markov times far beyond the run: GTSAM's random walk)."""
    w = short_world(duration_s=20.0, **{"imu.gyro_drift_time_s": 1e6,
                                        "imu.accel_drift_time_s": 1e6})
    runs, nees = 6, []
    for r in range(runs):
        rng = np.random.default_rng(100 + r)
        log = simulate(w, rng)
        s = fr._reference(log, *fr.ins_prior(log, rng))
        assert not s.diverged, s.failure
        nees.append(s.nees)
    lo, hi = anees_band(runs, 9)
    assert lo < np.mean(nees) / 9 < hi


def test_a_numerical_failure_is_a_counted_divergence() -> None:
    w = short_world()
    rng = np.random.default_rng(1)
    log = simulate(w, rng)
    bad = log.gnss_p.copy()
    bad[2, 0] = np.inf
    from dataclasses import replace

    s = fr.run_ins(replace(log, gnss_p=bad), "ins-srckf", *fr.ins_prior(log, rng))
    assert s.diverged and "non-finite" in (s.failure or "")
    out = fr.run_once(w, 0, np.random.SeedSequence(3), ["ea-ukf"], reference=False)
    assert set(out.scores) == {"ea-ukf"} and REFERENCE not in out.scores
