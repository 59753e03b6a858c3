"""The planar Bailey-style simulation."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from slam.kinds.planar.log import PlanarLog, load_log, save_log
from slam.kinds.planar.simulate import simulate_planar
from slam.kinds.planar.world import World
from slam.registry import load_world
from tests.small_worlds import small_world
from worlds import WorldError


@pytest.fixture(scope="module")
def bailey() -> World:
    return load_world("bailey")


def sim(world: World, seed: int = 0, **kw) -> PlanarLog:
    return simulate_planar(world, np.random.default_rng(seed), **kw)


def fields_equal(a: PlanarLog, b: PlanarLog) -> bool:
    return all(
        np.array_equal(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
    )


def test_log_shapes_and_nominal_noise(bailey: World) -> None:
    log = sim(bailey)
    k, m = log.n_steps, len(log.obs_step)
    assert log.truth.shape == (k + 1, 3) and log.controls.shape == (k, 2)
    assert log.obs.shape == (m, 2) and log.obs_id.shape == (m,) and m > 0
    assert log.obs_step.dtype == np.int64 and log.obs_id.dtype == np.int64
    assert log.dt == 0.025 and log.wheelbase == 4.0
    assert np.array_equal(log.x0, bailey.vehicle.start) and np.array_equal(log.P0, np.zeros((3, 3)))
    assert np.array_equal(log.truth[0], log.x0)
    assert np.allclose(log.control_cov, np.diag([0.3**2, math.radians(3.0) ** 2]))
    assert np.allclose(log.obs_cov, np.diag([0.1**2, math.radians(1.0) ** 2]))
    assert np.array_equal(log.landmarks, bailey.map.landmarks)


def test_same_seed_same_log_different_seed_different_noise(bailey: World) -> None:
    a, b, c = sim(bailey, 7), sim(bailey, 7), sim(bailey, 8)
    assert fields_equal(a, b)
    # the truth does not depend on the noise (the start is known exactly) ...
    assert np.array_equal(a.truth, c.truth) and np.array_equal(a.obs_step, c.obs_step)
    # ... but what the filters see does
    assert not np.array_equal(a.controls, c.controls)
    assert not np.array_equal(a.obs, c.obs)


def replay(x0: np.ndarray, controls: np.ndarray, dt: float, wb: float) -> np.ndarray:
    """Bailey's car model written out independently of slam.kinds.planar.simulate."""
    out = [tuple(float(v) for v in x0)]
    for v, g in controls.tolist():
        x, y, phi = out[-1]
        phi_new = phi + v * dt * math.sin(g) / wb
        phi_new = (phi_new + math.pi) % (2 * math.pi) - math.pi
        out.append((x + v * dt * math.cos(g + phi), y + v * dt * math.sin(g + phi), phi_new))
    return np.array(out)


def test_noise_free_log_replays_exactly(bailey: World) -> None:
    log = sim(bailey, noise_scale=0.0)
    assert np.all(log.controls[:, 0] == bailey.vehicle.speed_mps)
    assert np.array_equal(replay(log.x0, log.controls, log.dt, log.wheelbase), log.truth)
    lm = log.landmarks[log.obs_id]
    pose = log.truth[log.obs_step]
    d = lm - pose[:, :2]
    assert np.allclose(log.obs[:, 0], np.hypot(d[:, 0], d[:, 1]), rtol=0, atol=1e-12)
    bearing = np.arctan2(d[:, 1], d[:, 0]) - pose[:, 2]
    assert np.allclose(np.angle(np.exp(1j * (log.obs[:, 1] - bearing))), 0.0, atol=1e-12)
    # the nominal covariances stay (the filters' tuning), even without noise
    assert np.all(np.diag(log.control_cov) > 0) and np.all(np.diag(log.obs_cov) > 0)


def test_noisy_controls_replay_only_approximately(bailey: World) -> None:
    log = sim(bailey)
    err = replay(log.x0, log.controls, log.dt, log.wheelbase)[:, :2] - log.truth[:, :2]
    assert np.abs(err).max() > 0.5  # dead reckoning from noisy controls drifts


def test_noise_has_the_stated_sigmas(bailey: World) -> None:
    clean, noisy = sim(bailey, 3, noise_scale=0.0), sim(bailey, 3)
    du = noisy.controls - clean.controls
    assert np.allclose(du.std(axis=0), [0.3, math.radians(3.0)], rtol=0.05)
    assert np.allclose(du.mean(axis=0), 0.0, atol=0.05 * np.array([0.3, math.radians(3.0)]))
    assert np.array_equal(noisy.obs_id, clean.obs_id)
    dz = noisy.obs - clean.obs
    dz[:, 1] = np.angle(np.exp(1j * dz[:, 1]))
    assert np.allclose(dz.std(axis=0), [0.1, math.radians(1.0)], rtol=0.1)
    half = small_world(noise={"sigma_speed_mps": 0.2})
    du = sim(half, 1).controls - sim(half, 1, noise_scale=0.0).controls
    assert np.isclose(du[:, 0].std(), 0.2, rtol=0.1)


def visible(world: World, pose: np.ndarray) -> np.ndarray:
    """Landmark ids the sensor should see from ``pose``, by brute force."""
    out = []
    for i, (lx, ly) in enumerate(world.map.landmarks.tolist()):
        dx, dy = lx - pose[0], ly - pose[1]
        in_range = dx * dx + dy * dy < world.sensor.max_range_m**2
        in_front = dx * math.cos(pose[2]) + dy * math.sin(pose[2]) > 0
        if in_range and (in_front or not world.sensor.front_half_plane):
            out.append(i)
    return np.array(out, dtype=np.int64)


@pytest.mark.parametrize("front", [True, False])
def test_observations_are_exactly_the_visible_landmarks(front: bool) -> None:
    world = small_world(vehicle={"loops": 2}, sensor={"front_half_plane": front, "period_steps": 5})
    log = sim(world, 2)
    p = world.sensor.period_steps
    assert np.all(log.obs_step % p == 0) and np.all(log.obs_step >= p)
    order = np.lexsort((log.obs_id, log.obs_step))
    assert np.array_equal(order, np.arange(len(order)))  # sorted by step, then id
    groups = log.observations_at()
    behind = 0
    for k in range(p, log.n_steps + 1, p):
        ids = log.obs_id[groups[k]] if k in groups else np.empty(0, np.int64)
        assert np.array_equal(ids, visible(world, log.truth[k])), k
        for i in ids:
            d = world.map.landmarks[i] - log.truth[k, :2]
            assert math.hypot(*d) < world.sensor.max_range_m
            body_x = d[0] * math.cos(log.truth[k, 2]) + d[1] * math.sin(log.truth[k, 2])
            behind += body_x <= 0
    assert (behind == 0) if front else (behind > 0)
    assert np.all((log.obs[:, 1] >= -math.pi) & (log.obs[:, 1] < math.pi))


def visits(truth: np.ndarray, waypoints: np.ndarray, reach: float, laps: int) -> list[int]:
    """Steps at which the vehicle first comes within ``reach`` of each waypoint, in order."""
    d = np.hypot(*(truth[None, :, :2] - waypoints[:, None, :]).transpose(2, 0, 1))
    steps, k = [], 0
    for _ in range(laps):
        for i in range(len(waypoints)):
            near = np.flatnonzero(d[i, k:] < reach)
            assert near.size, f"waypoint {i} never reached after step {k}"
            k += int(near[0])
            steps.append(k)
    return steps


@pytest.mark.parametrize("loops", [1, 2, 3])
def test_vehicle_visits_every_waypoint_in_order(loops: int) -> None:
    world = small_world(vehicle={"loops": loops})
    log = sim(world)
    wps, reach = world.map.waypoints, world.vehicle.at_waypoint_m
    steps = visits(log.truth, wps, reach, loops)
    assert steps[-1] == log.n_steps  # stops as the last waypoint of the last lap is reached
    # one lap of the 30 m square is 120 m (1600 steps at 3 m/s, 0.025 s) plus corner overshoot
    assert 1550 * loops < log.n_steps < 1800 * loops
    turn_radius = world.vehicle.wheelbase_m / math.sin(world.vehicle.max_steer_rad)
    assert off_path(log.truth[:, :2], np.vstack([wps[-1], wps])).max() < turn_radius


def off_path(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """Distance of each point to the nearest segment of ``polyline``."""
    a, b = polyline[:-1], polyline[1:]
    ab = b - a
    t = np.clip(np.einsum("psi,si->ps", points[:, None] - a[None], ab) / (ab**2).sum(1), 0, 1)
    nearest = a[None] + t[..., None] * ab[None]
    return np.hypot(*(points[:, None] - nearest).transpose(2, 0, 1)).min(axis=1)


def test_bailey_drives_two_clockwise_laps(bailey: World) -> None:
    log = sim(bailey)
    steps = visits(log.truth, bailey.map.waypoints, bailey.vehicle.at_waypoint_m, 2)
    assert steps[-1] == log.n_steps
    heading_turn = np.sum(np.angle(np.exp(1j * np.diff(log.truth[:, 2]))))
    assert math.isclose(heading_turn, -4 * math.pi, abs_tol=0.5)  # two clockwise turns
    clean = sim(bailey, noise_scale=0.0).controls[:, 1]  # the true steer angles
    assert np.abs(clean).max() <= bailey.vehicle.max_steer_rad
    rate = bailey.vehicle.steer_rate_rad_s * bailey.vehicle.dt_s
    assert np.abs(np.diff(np.concatenate([[0.0], clean]))).max() <= rate + 1e-15


def test_initial_pose_sigma() -> None:
    world = small_world(vehicle={"initial_sigma_xy_m": 0.5, "initial_sigma_heading_deg": 2.0})
    log = sim(world, 4)
    assert np.array_equal(log.x0, world.vehicle.start)
    assert np.allclose(np.diag(log.P0), [0.25, 0.25, math.radians(2.0) ** 2])
    starts = np.array([sim(world, s).truth[0] for s in range(40)]) - log.x0
    assert np.all(starts.std(axis=0) > [0.3, 0.3, math.radians(1.2)])
    assert np.array_equal(sim(world, 4, noise_scale=0.0).truth[0], log.x0)


def test_unreachable_waypoint_is_reported() -> None:
    world = small_world(waypoints=[[0.0, 4.0], [20.0, 20.0]])  # inside the turning circle
    with pytest.raises(WorldError) as info:
        sim(world)
    assert info.value.key == "map.waypoints" and "did not reach waypoint 0" in str(info.value)


def test_save_load_round_trip(tmp_path: Path, bailey: World) -> None:
    log = sim(bailey, 5)
    path = tmp_path / "run.npz"
    save_log(log, path)
    back = load_log(path)
    for f in dataclasses.fields(PlanarLog):
        a, b = getattr(log, f.name), getattr(back, f.name)
        assert np.array_equal(a, b) and np.asarray(a).dtype == np.asarray(b).dtype, f.name
    assert isinstance(back.dt, float) and back.n_steps == log.n_steps

