"""Star-sensor attitude (seed 004 §5.1-5.2): world files, simulation, the quaternion filters
against an independent rotation-matrix implementation, the GTSAM smoother, a campaign."""

from __future__ import annotations

import copy
import json
import math
import tomllib
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import slam.kinds.attitude.run as att
from estimators import Transition
from nav.quaternion import qlog, qmul, qpropagate, qto_dcm
from nav.spaces import UnitQuaternion
from slam.kinds import load_world, world_from_dict
from slam.kinds.attitude.simulate import simulate_attitude
from slam.kinds.attitude.world import AttitudeWorld
from worlds import WorldError

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DEG_H = DEG / 3600.0
FILTERS = ["srckf", "srukf", "srcdkf", "ekf"]


def world_data(**overrides: Any) -> dict[str, Any]:
    """The bundled star-sensor document with dotted-key overrides (``"gyro.rate_hz"``)."""
    raw = (files("worlds") / "star-sensor.toml").read_bytes()
    data = copy.deepcopy(tomllib.loads(raw.decode("utf-8")))
    for dotted, value in overrides.items():
        *head, last = dotted.split(".")
        table = data
        for key in head:
            table = table.setdefault(key, {})
        table[last] = value
    return data


def make_world(**overrides: Any) -> AttitudeWorld:
    return world_from_dict(world_data(**overrides), name="test-attitude")


def short_world(duration: float = 60.0, **overrides: Any) -> AttitudeWorld:
    return make_world(**{"duration_s": duration,
                         "scoring.steady_state_from_s": duration / 2, **overrides})


# --------------------------------------------------------------------------- world files


def test_bundled_attitude_worlds_load() -> None:
    w = load_world("star-sensor")
    assert isinstance(w, AttitudeWorld) and w.kind == "attitude"
    assert (w.duration_s, w.runs, w.n_star, w.samples_per_star) == (600.0, 50, 1201, 25)
    assert w.filters.names == ("srckf", "srukf", "srcdkf", "ekf")
    assert math.isclose(w.gyro.arw_rad_sqrt_s, 0.05 * DEG / 60.0)
    assert math.isclose(w.gyro.bias_rw_rad_s_sqrt_s, 0.02 * DEG_H / 60.0)
    assert np.allclose(w.gyro.bias_rad_s, 0.1 * DEG_H)
    assert math.isclose(w.star.sigma_rad, 20.0 * ARCSEC) and w.star.mode == "quaternion"
    assert math.isclose(w.filters.initial_attitude_var_rad2, 0.25 * DEG**2)
    assert math.isclose(w.filters.initial_bias_var_rad2_s2, 0.2 * DEG_H**2)
    assert np.allclose(w.filters.initial_error_rad, np.array([0.5, 0.5, 5.0]) * DEG)
    assert np.allclose(w.satellite.initial_attitude_rad, np.array([0.0, 0.0, 5.0]) * DEG)
    assert w.scoring.steady_state_from_s == 300.0 and not w.scoring.report_convergence
    assert w.paper["filters"]["srckf"] == {"roll_arcsec": 3.0, "pitch_arcsec": 5.0,
                                           "yaw_arcsec": 2.0, "time_per_iteration_s": 0.012}
    json.dumps(w.paper)
    big = load_world("star-sensor-large-error")
    assert big.duration_s == 300.0 and big.scoring.report_convergence
    assert np.allclose(big.filters.initial_error_rad, np.array([30.0, 30.0, 60.0]) / 60 * DEG)


@pytest.mark.parametrize(
    ("overrides", "key"),
    [
        ({"star_sensor.rate_hz": 3.0}, "star_sensor.rate_hz"),  # 50 Hz / 3 Hz not whole
        ({"star_sensor.mode": "euler"}, "star_sensor.mode"),
        ({"scoring.steady_state_from_s": 600.0}, "scoring.steady_state_from_s"),
        ({"filters.initial_error_deg": [0.5, 0.5]}, "filters.initial_error_deg"),
        ({"gyro.arw_deg_sqrt_h": -0.05}, "gyro.arw_deg_sqrt_h"),
        ({"filters.star_sigma_arcsec": 0.0}, "filters.star_sigma_arcsec"),
        ({"gyro.arw_deg_sqrt_hour": 0.05}, "gyro.arw_deg_sqrt_hour"),  # misspelt key
        ({"filters.names": ["srckf", "kalman"]}, "filters.names[1]"),
        ({"duration_s": 600.25}, "duration_s"),
        ({"star_sensor.mode": "vectors", "star_sensor.directions": [[1, 0, 0], [2, 0, 0]]},
         "star_sensor.directions"),
        ({"star_sensor.n_stars": 3, "star_sensor.directions": [[1, 0, 0], [0, 1, 0]]},
         "star_sensor.directions"),
    ],
)
def test_malformed_attitude_world_names_the_key(overrides: dict, key: str) -> None:
    with pytest.raises(WorldError) as info:
        make_world(**overrides)
    assert info.value.key == key


def test_malformed_attitude_world_file_names_the_file(tmp_path: Path) -> None:
    text = (files("worlds") / "star-sensor.toml").read_text(encoding="utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("rate_hz = 50.0", "rate_hz = -50.0"), encoding="utf-8")
    with pytest.raises(WorldError) as info:
        load_world(bad)
    assert info.value.key == "gyro.rate_hz" and str(bad) in str(info.value)
    missing = tmp_path / "missing.toml"
    start = text.index("[gyro]")
    missing.write_text(text[:start] + text[text.index("[star_sensor]"):], encoding="utf-8")
    with pytest.raises(WorldError, match=r"gyro.*missing section"):
        load_world(missing)


# --------------------------------------------------------------------------- kernels, simulation


def test_noise_free_log_reproduces_the_truth() -> None:
    w = short_world(30.0, **{"gyro.arw_deg_sqrt_h": 0.0, "gyro.bias_rw_deg_h_sqrt_h": 0.0,
                             "star_sensor.sigma_arcsec": 0.0})
    log = simulate_attitude(att.sim_config(w), np.random.default_rng(0))
    assert log.gyro.shape == (1500, 3) and log.star_q.shape == (61, 4)
    q = log.truth_q[0]
    for k in range(log.gyro.shape[0]):  # ideal integrating gyro: exact increments
        q = qpropagate(q, log.gyro[k] - log.truth_bias[k], log.dt)
    assert np.linalg.norm(qlog(qmul(q * [1, -1, -1, -1], log.truth_q[-1]))) < 1e-11
    assert np.abs(log.star_q - log.star_truth_q).max() < 1e-15
    assert np.allclose(log.truth_bias, 0.1 * DEG_H, rtol=0, atol=1e-20)
    # the body rate relative to inertial space turns with the orbit: not constant
    rates = log.gyro - log.truth_bias[:-1]
    assert np.abs(rates[-1] - rates[0]).max() > 1e-5


def test_simulated_noise_levels_and_reproducibility() -> None:
    w = short_world(300.0, **{"gyro.bias_rw_deg_h_sqrt_h": 100.0})
    cfg = att.sim_config(w)
    log = simulate_attitude(cfg, np.random.default_rng(7))
    again = simulate_attitude(cfg, np.random.default_rng(7))
    assert np.array_equal(log.gyro, again.gyro) and np.array_equal(log.star_q, again.star_q)
    truth = simulate_attitude(att.sim_config(short_world(
        300.0, **{"gyro.arw_deg_sqrt_h": 0.0, "gyro.bias_rw_deg_h_sqrt_h": 0.0,
                  "star_sensor.sigma_arcsec": 0.0})), np.random.default_rng(7))
    arw = log.gyro - (truth.gyro - truth.truth_bias[:-1]) - log.truth_bias[:-1]
    assert math.isclose(arw.std(), w.gyro.arw_rad_sqrt_s / math.sqrt(log.dt), rel_tol=0.03)
    steps = np.diff(log.truth_bias, axis=0)
    assert math.isclose(steps.std(), w.gyro.bias_rw_rad_s_sqrt_s * math.sqrt(log.dt),
                        rel_tol=0.03)
    star = UnitQuaternion().local(log.star_truth_q, log.star_q)
    assert math.isclose(star.std(), w.star.sigma_rad, rel_tol=0.06)


# --------------------------------------------------------------------------- filters


def test_noise_free_filters_reach_the_truth() -> None:
    """Exact data, nominal assumed noises: every filter ends within 0.01″ of the truth.

    The initial error is 1σ of the prior and the bias prior is widened to 10 deg/h so
    that the remaining error is not the prior's (with the world's 0.45 deg/h prior the
    0.1 deg/h drift is still 13 % unlearnt after 300 s: the angle random walk limits it).
    """
    w = short_world(300.0, **{"gyro.arw_deg_sqrt_h": 0.0, "gyro.bias_rw_deg_h_sqrt_h": 0.0,
                              "star_sensor.sigma_arcsec": 0.0,
                              "filters.initial_error_deg": [0.5, 0.5, 0.5],
                              "filters.initial_bias_var_deg_h2": 100.0})
    out = att.run_once(w, 0, np.random.SeedSequence(0), FILTERS, reference=False)
    last = out.scores["srckf"].err_body.shape[0] - 201  # the last 100 s (2 Hz)
    for name in FILTERS:
        s = out.scores[name]
        assert not s.diverged, s.failure
        err = np.linalg.norm(s.err_body[last:], axis=1)
        assert err.max() < 0.01 * ARCSEC, (name, err.max() / ARCSEC)
        assert np.abs(s.err_bias[-1]).max() < 0.002 * DEG_H


def _rodrigues(phi: np.ndarray) -> np.ndarray:
    """exp([φ×]) for φ (..., 3) -> (..., 3, 3), independent of nav.quaternion."""
    t = np.linalg.norm(phi, axis=-1)[..., None, None]
    K = np.zeros(phi.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -phi[..., 2], phi[..., 1], -phi[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    a = np.where(small, 1.0 - t**2 / 6.0 + t**4 / 120.0, np.sin(ts) / ts)
    b = np.where(small, 0.5 - t**2 / 24.0 + t**4 / 720.0, (1.0 - np.cos(ts)) / ts**2)
    return np.eye(3) + a * K + b * (K @ K)


def _so3_log(R: np.ndarray) -> np.ndarray:
    """log of rotation matrices (..., 3, 3) -> (..., 3), angles well below π."""
    v = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                        R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    s = np.linalg.norm(v, axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    t = np.arctan2(s, c)
    k = np.where(s < 1e-8, 1.0 + t**2 / 6.0, t / np.where(s < 1e-8, 1.0, s))
    return k[..., None] * v


def _so3_mean(Rs: np.ndarray, w: np.ndarray) -> np.ndarray:
    R = Rs[np.argmax(w)]
    for _ in range(50):
        step = w @ _so3_log(R.T @ Rs)
        R = R @ _rodrigues(step)
        if np.linalg.norm(step) < 1e-15:
            break
    return R


def _propagate_dcm(R: np.ndarray, b: np.ndarray, gyro: np.ndarray, dt: float) -> np.ndarray:
    for w in gyro:  # sequential, sample by sample
        R = R @ _rodrigues((w - b) * dt)
    return R


def dcm_ckf(log, x0, P0, Q, sigma):
    """Cubature Kalman filter on (R ∈ SO(3), b) with rotation-vector errors R = R̂ Exp(δ)."""
    R, b, P = qto_dcm(x0[:4]), x0[4:].copy(), P0.copy()
    n = 6
    xi = math.sqrt(n) * np.vstack([np.eye(n), -np.eye(n)])
    wts = np.full(2 * n, 1.0 / (2 * n))
    Rn = sigma**2 * np.eye(3)

    def points(R, b, P):
        d = xi @ np.linalg.cholesky(P).T
        return R @ _rodrigues(d[:, :3]), b + d[:, 3:], d

    def update(R, b, P, z):
        Rs, bs, d = points(R, b, P)
        zh = _so3_mean(Rs, wts)
        dz = _so3_log(zh.T @ Rs)
        Pzz = (dz.T * wts) @ dz + Rn
        Pxz = (d.T * wts) @ dz
        K = Pxz @ np.linalg.inv(Pzz)
        dx = K @ _so3_log(zh.T @ z)
        return R @ _rodrigues(dx[:3]), b + dx[3:], P - K @ Pzz @ K.T

    out = []
    R, b, P = update(R, b, P, qto_dcm(log.star_q[0]))
    out.append((R, b, P))
    for j in range(1, log.n_star):
        Rs, bs, _ = points(R, b, P)
        Ys = np.stack([_propagate_dcm(Ri, bi, log.gyro_block(j - 1), log.dt)
                       for Ri, bi in zip(Rs, bs)])
        R = _so3_mean(Ys, wts)
        b = wts @ bs
        d = np.hstack([_so3_log(R.T @ Ys), bs - b])
        P = (d.T * wts) @ d + Q
        R, b, P = update(R, b, P, qto_dcm(log.star_q[j]))
        out.append((R, b, P))
    return out


def _right_jacobian(phi: np.ndarray) -> np.ndarray:
    t = np.linalg.norm(phi)
    K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if t < 1e-4:
        return np.eye(3) - 0.5 * K + K @ K / 6.0
    return np.eye(3) - (1 - math.cos(t)) / t**2 * K + (t - math.sin(t)) / t**3 * (K @ K)


def dcm_mekf(log, x0, P0, Q, sigma):
    """Multiplicative EKF on (R, b) with analytic Jacobians and a Joseph update."""
    R, b, P = qto_dcm(x0[:4]), x0[4:].copy(), P0.copy()
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    Rn = sigma**2 * np.eye(3)

    def update(R, b, P, z):
        nu = _so3_log(R.T @ z)
        S = H @ P @ H.T + Rn
        K = P @ H.T @ np.linalg.inv(S)
        A = np.eye(6) - K @ H
        dx = K @ nu
        return R @ _rodrigues(dx[:3]), b + dx[3:], A @ P @ A.T + K @ Rn @ K.T

    out = []
    R, b, P = update(R, b, P, qto_dcm(log.star_q[0]))
    out.append((R, b, P))
    for j in range(1, log.n_star):
        phis = (log.gyro_block(j - 1) - b) * log.dt
        Es = _rodrigues(phis)
        F = np.eye(6)
        suffix = np.eye(3)  # Π_{l>k} Exp(φ_l), built from the last sample backwards
        Fb = np.zeros((3, 3))
        for k in range(len(phis) - 1, -1, -1):
            Fb -= suffix.T @ _right_jacobian(phis[k]) * log.dt
            suffix = Es[k] @ suffix
        F[:3, :3], F[:3, 3:] = suffix.T, Fb
        R = R @ suffix
        P = F @ P @ F.T + Q
        R, b, P = update(R, b, P, qto_dcm(log.star_q[j]))
        out.append((R, b, P))
    return out


@pytest.fixture(scope="module")
def noisy_run():
    w = short_world(40.0)
    log = simulate_attitude(att.sim_config(w), np.random.default_rng(3))
    x0, P0 = att.initial_belief(w, log)
    fs = w.filters
    trans = att.interval_transition(25, log.dt, fs.arw_rad_sqrt_s, fs.bias_rw_rad_s_sqrt_s)
    meas = att.star_measurement("quaternion", fs.star_sigma_rad)
    return w, log, x0, P0, trans, meas


def _compare(series, reference, log) -> tuple[float, float, float]:
    att_err = max(np.linalg.norm(_so3_log(Rr.T @ qto_dcm(q)))
                  for (Rr, _, _), q in zip(reference, series.means[:, :4]))
    bias_err = max(np.abs(br - b).max() for (_, br, _), b in zip(reference, series.means[:, 4:]))
    cov_err = max(np.abs(Pr - P).max() / np.abs(Pr).max()
                  for (_, _, Pr), P in zip(reference, series.covs))
    return att_err, bias_err, cov_err


@pytest.mark.parametrize("name", ["ckf", "srckf"])
def test_cubature_filters_match_a_rotation_matrix_ckf(noisy_run, name: str) -> None:
    """Same algorithm, different representation (DCM, sequential propagation, own
    Rodrigues/Log): agreement to round-off (~2e-16 rad in attitude here)."""
    w, log, x0, P0, trans, meas = noisy_run
    ref = dcm_ckf(log, x0, P0, trans.noise.cov, w.filters.star_sigma_rad)
    series = att.run_filter(log, name, x0, P0, trans, meas)
    assert not series.diverged
    a, b, c = _compare(series, ref, log)
    assert a < 1e-12 and b < 1e-15 and c < 1e-8, (a, b, c)


def test_mekf_matches_a_rotation_matrix_mekf_with_analytic_jacobians(noisy_run) -> None:
    """``ekf`` differentiates the batched transition numerically (central differences,
    step 1e-6): it agrees with analytic Jacobians to ~4e-15 rad in attitude here; the
    bound leaves room for the difference quotient's round-off on other platforms."""
    w, log, x0, P0, trans, meas = noisy_run
    ref = dcm_mekf(log, x0, P0, trans.noise.cov, w.filters.star_sigma_rad)
    series = att.run_filter(log, "ekf", x0, P0, trans, meas)
    assert not series.diverged
    a, b, c = _compare(series, ref, log)
    assert a < 1e-11 and b < 1e-14 and c < 1e-7, (a, b, c)


def test_filter_failure_is_reported_as_divergence(noisy_run) -> None:
    w, log, x0, P0, trans, meas = noisy_run

    def broken(X, u):
        out = trans.f(X, u)
        out[:, 4:] = np.nan
        return out

    bad = Transition(broken, trans.noise)
    for name in ("srckf", "ekf"):
        series = att.run_filter(log, name, x0, P0, bad, meas)
        assert series.diverged and series.failure
        scores = att.score_series(series, log, w.scoring.divergence_rad)
        assert scores.diverged
    summary = att.summarize_scores([scores], log.star_times, 20.0)
    assert summary["diverged_runs"] == 1 and summary["runs_scored"] == 0


def test_vector_mode_end_to_end() -> None:
    w = short_world(30.0, **{"star_sensor.mode": "vectors", "star_sensor.n_stars": 3,
                             "filters.initial_error_deg": [0.5, 0.5, 1.0]})
    out = att.run_once(w, 0, np.random.SeedSequence(5), FILTERS)
    for name, s in out.scores.items():
        assert not s.diverged, (name, s.failure)
        assert np.sqrt(np.mean(s.err_body[20:] ** 2)) < 15 * ARCSEC, name
        assert s.nis_dof in (0, 9)


# --------------------------------------------------------------------------- smoother


def test_smoother_recovers_a_constant_drift() -> None:
    drift = np.array([20.0, -10.0, 15.0])  # deg/h; angle random walk limits it to ~0.2 deg/h
    w = short_world(300.0, **{"gyro.bias_deg_h": drift.tolist(),
                              "gyro.bias_rw_deg_h_sqrt_h": 0.0,
                              "filters.initial_bias_var_deg_h2": 1e4})
    log = simulate_attitude(att.sim_config(w), np.random.default_rng(11))
    x0, P0 = att.initial_belief(w, log)
    fs = w.filters
    s = att.smooth_attitude(log, x0, P0, fs.arw_rad_sqrt_s, fs.bias_rw_rad_s_sqrt_s,
                            fs.star_sigma_rad, marginals=False)
    bias = s.means[:, 4:] / DEG_H
    assert np.abs(bias - drift).max() < 0.03 * np.linalg.norm(drift)
    err = UnitQuaternion().local(s.means[:, :4], log.star_truth_q)
    assert np.sqrt(np.mean(err**2)) < 10 * ARCSEC


def test_convergence_time() -> None:
    t = np.arange(6.0)
    assert att.convergence_time(np.array([5, 3, 0.5, 2, 0.5, 0.1]), t, 1.0) == 4.0
    assert att.convergence_time(np.array([0.5, 0.1, 0.2, 0.1, 0.5, 0.1]), t, 1.0) == 0.0
    assert math.isnan(att.convergence_time(np.array([0.5, 0.1, 0.2, 0.1, 0.5, 3]), t, 1.0))


# --------------------------------------------------------------------------- campaign


def test_small_campaign_end_to_end(tmp_path: Path) -> None:
    from slam.campaign import run_campaign
    from slam.kinds.attitude.report import REPORT, attitude_tables, figure_writers

    w = short_world(60.0, **{"runs": 3, "scoring.report_convergence": True})
    result = run_campaign(w, workers=1)
    s = result.summary
    assert s["kind"] == "attitude" and s["runs"] == 3 and s["steady_state_window_s"] == [30, 60]
    assert set(s["filters"]) == set(FILTERS) and s["paper"] == w.paper
    for name, e in [*s["filters"].items(), ("gtsam", s["reference"]["gtsam"])]:
        assert e["diverged_runs"] == 0, name
        for key in ("att_mean_abs_arcsec", "att_mean_abs_steady_arcsec", "att_rms_steady_arcsec"):
            assert set(e[key]) == {"roll", "pitch", "yaw"}
            assert all(0.0 < v < 30.0 for v in e[key].values()), (name, key, e[key])
        assert 0.0 < e["bias_rmse_deg_h"] < 5.0
        lo, hi = e["anees_bounds_95"]
        assert lo < 1.0 < hi and 0.0 < e["anees"] < 10.0
        assert e["converge_below_1arcmin_s"] is not None
    for e in s["filters"].values():
        assert e["time_per_cycle_s"] > 0.0
    assert s["reference"]["gtsam"]["time_s"] > 0.0
    json.dumps(s, allow_nan=False)
    table = attitude_tables(s)
    assert "srckf" in table and "Paper's Table 2" in table and "ekf (MEKF)" in table
    for fname, draw in figure_writers().items():
        draw(result, tmp_path / fname)
        assert (tmp_path / fname).stat().st_size > 10_000
    titles = [sec.title for sec in REPORT.sections(s)]
    assert titles[:2] == ["Results", "Convergence"] and "How to read this" in titles
    assert set(REPORT.figures()) == set(figure_writers())
    assert "srckf" in REPORT.text_table(s)
