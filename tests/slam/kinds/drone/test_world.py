"""Drone world files (:mod:`slam.kinds.drone.world`): the bundled worlds, errors that name
the key, a mesh-file terrain.
"""

from __future__ import annotations

import dataclasses
import json
from importlib.resources import files
from typing import Any

import numpy as np
import pytest

from slam.kinds.drone.truth import terrain_of, truth_of
from slam.registry import load_world, world_from_dict
from tests.small_worlds import DRONE_FILTERS, small_drone_doc
from worlds import WorldError

FILTERS = DRONE_FILTERS


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


def test_the_large_yaw_world_changes_only_the_initial_attitude_and_adds_invariant_filters():
    """``drone-large-yaw`` is the paper's drone started from a coarse alignment (roll/pitch
    σ 2°, yaw σ 10°), with the invariant variants beside the paper's four; its first line
    says what was made harder."""
    hard, paper = load_world("drone-large-yaw"), load_world("drone")
    assert (hard.map, hard.terrain, hard.imu, hard.sensor) == (
        paper.map, paper.terrain, paper.imu, paper.sensor)
    assert np.isclose(hard.vehicle.initial_sigma_yaw_rad, np.radians(10.0))
    assert np.isclose(hard.vehicle.initial_sigma_roll_pitch_rad, np.radians(2.0))
    assert hard.vehicle == dataclasses.replace(
        paper.vehicle, initial_sigma_yaw_rad=hard.vehicle.initial_sigma_yaw_rad,
        initial_sigma_roll_pitch_rad=hard.vehicle.initial_sigma_roll_pitch_rad)
    assert hard.filters.names == (*paper.filters.names, "ekf-inv", "srckf-inv")
    assert hard.filters.settings_of("srukf") == paper.filters.settings_of("srukf")
    assert hard.paper["filters"] == paper.paper["filters"] and hard.runs == 10
    text = (files("worlds") / "drone-large-yaw.toml").read_text(encoding="utf-8")
    first = text.splitlines()[0]
    assert first.startswith("# Harder: ") and "[Wang SRCKF-SLAM]" in first


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
    doc = small_drone_doc()
    change(doc)
    with pytest.raises(WorldError) as err:
        world_from_dict(doc, name="bad", source="bad.toml")
    text = str(err.value)
    assert text.startswith("bad.toml: ") and key in text and message in text, text


def test_mesh_file_world(tmp_path):
    from nav.terrain import Terrain

    Terrain.hills((-30, 60, -30, 60), [[15.0, 15.0]], 4.0, 6.0, spacing=3.0).mesh.export(
        tmp_path / "field.ply")
    doc = small_drone_doc()
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
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {val(x)}" for k, x in v.items()) + "}"
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
