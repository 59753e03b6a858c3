"""Drone quaternion SINS/SLAM: world files, simulation, models, filters, smoother, reports."""

from __future__ import annotations

import json
import math
import time
from typing import Any

import numpy as np
import pytest
import trimesh

from estimators.ekf import numerical_jacobian
from slam.kinds import load_world, world_from_dict
from slam.kinds.drone import models as dm
from slam.kinds.drone.report import (
    REPORT,
    drone_figures,
    drone_text_table,
    write_scene_glb,
)
from slam.kinds.drone.run import (
    IMU_ONLY,
    imu_only,
    run_drone_filter,
    run_once,
    score,
    simulate_drone,
    summarize_drone,
    terrain_of,
    truth_of,
)
from slam.render.output import write_outputs
from slam.results import REFERENCE, CampaignResult
from worlds import WorldError

FILTERS = ("ekf", "srckf", "srukf", "srcdkf")


def small_doc(**sections: Any) -> dict[str, Any]:
    """A 30 m square loop (counter-clockwise from the origin) among 4 landmarks, one hill."""
    doc: dict[str, Any] = {
        "kind": "drone-slam",
        "description": "Test world: 30 m square loop over a hill, 4 landmarks",
        "runs": 2,
        "seed": 0,
        "map": {"bounds_m": [-20.0, 50.0, -20.0, 50.0],
                "landmarks": [[15.0, -6.0], [36.0, 15.0], [15.0, 36.0], [-6.0, 15.0]],
                "waypoints": [[30.0, 0.0], [30.0, 30.0], [0.0, 30.0], [0.0, 0.0]]},
        "terrain": {"type": "hills", "hill_centres_m": [[15.0, 15.0]], "hill_amplitude_m": 4.0,
                    "hill_width_m": 6.0, "grid_spacing_m": 3.0},
        "vehicle": {"loops": 1, "start_xy_m": [0.0, 0.0], "start_heading_deg": 0.0,
                    "speed_mps": 4.0},
        "filters": {"names": list(FILTERS)},
        "paper": {"filters": {"srckf": {"pos_err_range_m": {"x": [-0.5, 0.6],
                                                            "y": [-0.5, 0.2],
                                                            "z": [-0.5, 0.05]}}}},
    }
    for key, value in sections.items():
        if isinstance(value, dict) and isinstance(doc.get(key), dict):
            doc[key] = {**doc[key], **value}
        else:
            doc[key] = value
    return doc


def small_world(**sections: Any):
    return world_from_dict(small_doc(**sections), name="small-drone")


# --------------------------------------------------------------------------- worlds

def signed_area(p: np.ndarray) -> float:
    return 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))


@pytest.mark.parametrize("name, terrain", [("drone", "flat"), ("drone-hills", "hills")])
def test_bundled_drone_worlds(name, terrain):
    w = load_world(name)
    assert w.kind == "drone-slam" and w.terrain.kind == terrain
    assert w.map.bounds_m == (0.0, 100.0, 0.0, 100.0) and w.map.landmarks.shape == (10, 2)
    assert signed_area(w.map.waypoints) < 0 and w.vehicle.start_xy == (60.0, 10.0)
    assert w.samples_per_epoch == 20 and set(w.filters.names) == set(FILTERS)
    paper = w.paper["filters"]
    assert paper["srckf"]["pos_err_range_m"] == {"x": [-0.5, 0.6], "y": [-0.5, 0.2],
                                                 "z": [-0.5, 0.05]}
    assert paper["srcdkf"]["pos_err_range_m"]["z"] == [-1.45, 2.2]
    json.dumps(w.paper)
    bailey = load_world("bailey")
    assert np.array_equal(w.map.landmarks, bailey.map.landmarks)
    assert np.array_equal(w.map.waypoints, bailey.map.waypoints)


def _set(section: str, **values: Any):
    def change(doc: dict[str, Any]) -> None:
        doc[section] = {**doc.get(section, {}), **values}
    return change


def _replace(section: str, **values: Any):
    def change(doc: dict[str, Any]) -> None:
        doc[section] = dict(values)
    return change


@pytest.mark.parametrize("change, key, message", [
    (_replace("terrain", type="flat", hill_centres_m=[[1.0, 1.0]]), "[terrain] hill_centres_m",
     "only used with"),
    (_set("terrain", hill_amplitude_m="high"), "[terrain] hill_amplitude_m", "must be a number"),
    (_replace("terrain", type="hills", hill_centres_m=[[1.0, 1.0]], hill_width_m=3.0),
     "[terrain] hill_amplitude_m", "missing"),
    (_replace("terrain", type="mesh"), "[terrain] mesh_file", "missing"),
    (_replace("terrain", type="mesh", mesh_file="x.obj"), "[terrain] mesh_file",
     "world file to be relative to"),
    (_set("sensor", rate_hz=7.0), "[sensor] rate_hz", "whole number"),
    (_set("sensor", min_range_m=40.0), "[sensor] min_range_m", "below max_range_m"),
    (_set("imu", gyro_arw_deg_s=0.1), "[imu] gyro_arw_deg_s", "unknown key"),
    (_set("vehicle", speed_mps=-1.0), "[vehicle] speed_mps", "must be in"),
    (_set("map", landmarks=[[100.0, 0.0]]), "[map] landmarks[0]", "outside"),
    (_set("filters", names=["srckf", "bogus"]), "[filters] names[1]", "unknown"),
])
def test_world_errors_name_the_key(change, key, message):
    doc = small_doc()
    change(doc)
    with pytest.raises(WorldError) as err:
        world_from_dict(doc, name="bad", source="bad.toml")
    text = str(err.value)
    assert text.startswith("bad.toml: ") and key in text and message in text, text


def test_mesh_file_world(tmp_path):
    from nav.terrain import Terrain

    Terrain.hills((-30, 60, -30, 60), [[15.0, 15.0]], 4.0, 6.0, spacing=3.0).mesh.export(
        tmp_path / "field.ply")
    doc = small_doc()
    doc["terrain"] = {"type": "mesh", "mesh_file": "field.ply"}
    (tmp_path / "w.toml").write_text(_to_toml(doc))
    w = load_world(tmp_path / "w.toml")
    assert w.terrain.mesh_path.endswith("field.ply")
    _, lms = truth_of(w)
    assert np.allclose(lms[:, 2], terrain_of(w).height(lms[:, :2]))
    doc["terrain"]["mesh_file"] = "missing.obj"
    (tmp_path / "w2.toml").write_text(_to_toml(doc))
    with pytest.raises(WorldError, match="mesh_file"):
        load_world(tmp_path / "w2.toml")


def _to_toml(doc: dict[str, Any]) -> str:
    def val(v: Any) -> str:
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)

    lines, tables = [], []
    for k, v in doc.items():
        (tables if isinstance(v, dict) else lines).append((k, v))
    out = [f"{k} = {val(v)}" for k, v in lines]
    for name, table in tables:
        if name == "paper":
            continue
        out.append(f"[{name}]")
        out += [f"{k} = {val(v)}" for k, v in table.items()]
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- simulation

def test_truth_keeps_height_and_landmarks_sit_on_the_terrain():
    w = small_world()
    traj, lms = truth_of(w)
    ter = terrain_of(w)
    assert np.allclose(lms[:, 2], ter.height(lms[:, :2]))
    agl = traj.p[:, 2] - ter.height(traj.p[:, :2])
    assert abs(np.median(agl) - w.vehicle.height_above_ground_m) < 0.3


def test_noise_free_log_is_reproduced_by_pure_mechanisation():
    w = small_world()
    log = simulate_drone(w, np.random.default_rng(0), noise_scale=0.0)
    s = score(imu_only(log), log)
    assert np.nanmax(np.abs(s.err_pos)) < 1e-9 and np.nanmax(np.abs(s.err_att)) < 1e-12


@pytest.mark.parametrize("name", FILTERS)
def test_filters_track_a_noise_free_log_with_tiny_assumed_noise(name):
    w = small_world()
    log = simulate_drone(w, np.random.default_rng(0), noise_scale=0.0)
    assert len(np.unique(log.obs_id)) == 4
    est = run_drone_filter(log, name, noise_scale=1e-12)
    s = score(est, log)
    assert not est.diverged, est.failure
    assert np.nanmax(np.abs(s.err_pos)) < 1e-6
    assert np.nanmax(np.abs(s.err_att)) < 1e-6
    assert len(s.lm_err) == 4 and np.max(s.lm_err) < 1e-6


def test_terrain_hides_landmarks_behind_a_hill():
    # a tall hill in the middle of the square hides the far side's landmarks
    doc = small_doc(terrain={"hill_amplitude_m": 25.0, "hill_width_m": 5.0},
                    vehicle={"height_above_ground_m": 2.0})
    seen = {}
    for los in (True, False):
        doc["sensor"] = {"line_of_sight": los}
        w = world_from_dict(doc, name="hill")
        seen[los] = simulate_drone(w, np.random.default_rng(1), noise_scale=0.0)
    assert 0 < len(seen[True].obs) < len(seen[False].obs)
    # every kept sighting has a clear line of sight
    log = seen[True]
    ter = terrain_of(w)
    e = log.obs_epoch
    assert ter.line_of_sight(log.truth[e, :3], log.landmarks[log.obs_id], 0.1).all()


# --------------------------------------------------------------------------- models

def _state(n_lm: int, rng: np.random.Generator) -> np.ndarray:
    from nav.quaternion import qexp

    x = np.concatenate([rng.normal(size=3) * 5, rng.normal(size=3), qexp(rng.normal(size=3)),
                        rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-2,
                        rng.normal(size=3 * n_lm) * 10 + 20])
    return x


def test_measurement_and_augmentation_jacobians_match_numerical():
    rng = np.random.default_rng(4)
    x = _state(3, rng)
    space = dm.state_space(3)
    slots = np.array([2, 0])
    meas = dm.observation_model(slots, np.eye(3))
    J, _ = numerical_jacobian(lambda X, W: meas.h(X), x, space, meas.space)
    assert np.allclose(meas.jacobian(x), J, atol=1e-6)
    z = dm.rae(x[None], slots)[0]
    aug = dm.augmentation_model(3, z, np.eye(6) * 0.01)
    Jn, y = numerical_jacobian(lambda X, W: aug.f(X, z, W), x, space, aug.space, nw=6)
    F, G = aug.jacobian(x, z)
    assert np.allclose(np.hstack([F, G]), Jn, atol=1e-6)
    # inverse observation of the observation gives the landmarks back
    assert np.allclose(y[-6:], x[dm.VEH_AMBIENT:][np.r_[6:9, 0:3]], atol=1e-9)


def test_transition_jacobian_close_to_numerical():
    rng = np.random.default_rng(7)
    x = _state(1, rng)
    gyro = rng.normal(size=(20, 3)) * 0.3
    acc = rng.normal(size=(20, 3)) + [0.0, 0.0, 9.8]
    nav = dm.NavFrame(0.01, np.array([0.0, 0.0, -9.80665]))
    noise = dm.ImuNoise(1e-4, 1e-3, 1e-6, 1e-5)
    model = dm.imu_transition(x, 1, gyro, acc, nav, noise)
    space = dm.state_space(1)
    Jn, y = numerical_jacobian(lambda X, W: model.f(X, (gyro, acc)), x, space, space)
    F = model.jacobian(x, (gyro, acc))
    assert np.max(np.abs(F - Jn)) < 2e-3 * np.max(np.abs(Jn))
    assert np.allclose(model.noise.sqrt @ model.noise.sqrt.T, model.noise.cov, atol=1e-15)
    # position variance of white accelerometer noise over T = 0.2 s: sigma^2 T^3 / 3
    assert model.noise.cov[0, 0] == pytest.approx(1e-6 * 0.2**3 / 3, rel=0.05)


def test_divergence_is_reported_not_raised():
    w = small_world()
    log = simulate_drone(w, np.random.default_rng(2))
    est = run_drone_filter(log, "srckf", diverge_m=1e-3)
    assert est.diverged and "position error" in est.failure
    s = score(est, log)
    from slam.kinds.drone.run import summarize_scores

    out = summarize_scores([s])
    assert out["diverged_runs"] == 1 and out["runs_scored"] == 0 and "pos_rmse_m" not in out


def test_nearest_neighbour_association_runs():
    w = small_world(filters={"names": ["srckf"], "association": "nn"})
    log = simulate_drone(w, np.random.default_rng(3))
    est = run_drone_filter(log, "srckf", association="nn")
    assert not est.diverged and len(est.landmark_ids) >= 4 and np.all(est.landmark_ids == -1)
    s = score(est, log)
    assert np.nanmax(np.linalg.norm(s.err_pos, axis=1)) < 3.0


# --------------------------------------------------------------------------- pipeline

def test_small_world_runs_the_whole_pipeline_in_under_15_s(tmp_path):
    t0 = time.perf_counter()
    w = small_world()
    seeds = np.random.SeedSequence(11).spawn(1)
    outs = [run_once(w, 0, seeds[0], list(FILTERS), True)]
    summary = summarize_drone(w, outs, list(FILTERS), 1, 11)
    result = CampaignResult(w, summary, outs)
    figures = drone_figures(result, tmp_path)
    glb = write_scene_glb(result, tmp_path / "scene.glb")
    elapsed = time.perf_counter() - t0
    assert elapsed < 15.0, f"pipeline took {elapsed:.1f} s"
    for name in FILTERS:
        entry = summary["filters"][name]
        assert entry["diverged_runs"] == 0
        assert set(entry["pos_err_range_m"]) == {"x", "y", "z"}
        assert entry["pos_rmse_m"] < 1.0 and entry["landmark_rmse_m"] < 1.0
        assert {"anees", "anees_bounds_95", "anees_pose6", "nis_mean",
                "time_per_step_s"} <= set(entry)
        assert set(entry["att_rmse_deg"]) == {"roll", "pitch", "yaw"}
    assert summary["reference"][REFERENCE]["pos_rmse_m"] < 1.0
    assert summary["baselines"][IMU_ONLY]["pos_rmse_m"] > summary["filters"]["srckf"][
        "pos_rmse_m"]
    assert "landmark_rmse_vs_gtsam" in summary["filters"]["srckf"]
    json.dumps(summary)
    for f in figures:
        assert (tmp_path / f).stat().st_size > 10_000
    scene = trimesh.load(glb)
    assert isinstance(scene, trimesh.Scene) and "terrain" in scene.geometry
    table = drone_text_table(summary)
    assert "z range" in table and IMU_ONLY in table and REFERENCE in table
    out = tmp_path / "report"
    names = [p.name for p in write_outputs(result, REPORT, out, plots=False)]
    assert {"summary.json", "report.md", "report.html", "scene.glb", "truth.tum"} <= set(names)
    assert REPORT.text_table(summary) == table
    md = (out / "report.md").read_text()
    assert "z paper (m)" in md and "[-0.50, +0.05]" in md
    assert math.isfinite(json.loads((out / "summary.json").read_text())["filters"]["srckf"][
        "pos_rmse_m"])
