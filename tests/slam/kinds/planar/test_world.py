"""Planar world files (:mod:`slam.kinds.planar.world`): the bundled worlds, and the
validator's refusals.
"""

from __future__ import annotations

import dataclasses
import json
import math
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

from slam.kinds.planar.world import World
from slam.registry import load_world
from tests.small_worlds import small_world
from worlds import WorldError

BUNDLED = ("bailey", "bailey-sparse", "webmap", "densemap")


def signed_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


# --------------------------------------------------------------------------- bundled worlds


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_world_loads(name: str) -> None:
    world = load_world(name)
    assert isinstance(world, World)
    assert world.name == name and world.kind == "planar-slam"
    assert world.source == f"worlds/{name}.toml"
    xmin, xmax, ymin, ymax = world.map.bounds_m
    for pts in (world.map.landmarks, world.map.waypoints):
        assert pts.ndim == 2 and pts.shape[1] == 2 and pts.dtype == np.float64
        assert np.all((pts[:, 0] >= xmin) & (pts[:, 0] <= xmax))
        assert np.all((pts[:, 1] >= ymin) & (pts[:, 1] <= ymax))
    assert set(world.filters.names) == {"ekf", "srckf", "srukf", "srcdkf"}
    json.dumps(world.paper)  # passes through to summary.json


def test_bailey_world_is_the_papers() -> None:
    w = load_world("bailey")
    assert w.map.bounds_m == (0.0, 100.0, 0.0, 100.0)
    assert w.map.landmarks.shape == (10, 2)
    assert signed_area(w.map.waypoints) < 0  # clockwise
    x, y, heading = w.vehicle.start
    assert (x, y) == (60.0, 10.0)
    wx, wy = w.map.waypoints[0]
    assert math.isclose(
        math.remainder(heading - math.atan2(wy - y, wx - x), 2 * math.pi), 0.0, abs_tol=1e-12
    )
    # Bailey's defaults, converted to radians
    v, s, n = w.vehicle, w.sensor, w.noise
    assert (v.speed_mps, v.wheelbase_m, v.dt_s, v.at_waypoint_m, v.loops) == (
        3.0,
        4.0,
        0.025,
        1.0,
        2,
    )
    assert math.isclose(v.max_steer_rad, math.radians(30.0))
    assert math.isclose(v.steer_rate_rad_s, math.radians(20.0))
    assert (s.max_range_m, s.period_steps, s.sigma_range_m, s.front_half_plane) == (
        30.0,
        8,
        0.1,
        True,
    )
    assert math.isclose(s.sigma_bearing_rad, math.radians(1.0))
    assert n.sigma_speed_mps == 0.3 and math.isclose(n.sigma_steer_rad, math.radians(3.0))
    assert w.runs == 50 and w.filters.names == ("ekf", "srckf", "srukf", "srcdkf")
    assert (w.filters.gate_accept, w.filters.gate_new) == (4.0, 25.0)
    assert w.paper["filters"]["srckf"]["pos_err_range_m"]["x"] == [-0.5, 0.6]
    assert w.paper["filters"]["srcdkf"]["pos_err_range_m"]["y"] == [-1.7, 1.1]
    # landmarks well separated
    d = np.hypot(*(w.map.landmarks[:, None] - w.map.landmarks[None]).transpose(2, 0, 1))
    assert d[~np.eye(10, dtype=bool)].min() > 15.0


def test_the_harder_bailey_world_changes_only_the_sensor_and_steering_noise() -> None:
    """``bailey-sparse`` is the paper's world with four of Bailey's config values changed
    (range, scan period, bearing and steering noise) and more runs; its first line says so."""
    hard, paper = load_world("bailey-sparse"), load_world("bailey")
    assert hard.map == paper.map and hard.vehicle == paper.vehicle
    assert hard.filters == paper.filters and hard.paper["filters"] == paper.paper["filters"]
    s, n = hard.sensor, hard.noise
    assert (s.max_range_m, s.period_steps, s.sigma_range_m, s.front_half_plane) == (
        15.0, 40, 0.1, True)
    assert math.isclose(s.sigma_bearing_rad, math.radians(3.0))
    assert n.sigma_speed_mps == 0.3 and math.isclose(n.sigma_steer_rad, math.radians(6.0))
    assert hard.runs == 80
    text = (files("worlds") / "bailey-sparse.toml").read_text(encoding="utf-8")
    first = text.splitlines()[0]
    assert first.startswith("# Harder: ") and "[Wang SRCKF-SLAM]" in first


def test_bailey_maps_from_data_files() -> None:
    web, dense = load_world("webmap"), load_world("densemap")
    assert web.map.landmarks.shape == (35, 2) and web.map.waypoints.shape == (17, 2)
    assert dense.map.landmarks.shape == (135, 2)
    assert np.array_equal(dense.map.waypoints, web.map.waypoints)
    assert np.array_equal(dense.map.landmarks[:35], web.map.landmarks)
    assert web.vehicle.start == (0.0, 0.0, 0.0) and (web.runs, dense.runs) == (20, 10)


def test_world_is_frozen() -> None:
    w = load_world("bailey")
    with pytest.raises(dataclasses.FrozenInstanceError):
        w.runs = 3  # type: ignore[misc]
    with pytest.raises(ValueError):
        w.map.landmarks[0, 0] = 1.0


# --------------------------------------------------------------------------- the validator

GOOD = """\
kind = "planar-slam"
description = "tiny"
runs = 3

[map]
bounds_m = [0.0, 50.0, 0.0, 50.0]
landmarks = [[10.0, 10.0], [40.0, 40.0]]
waypoints = [[40.0, 5.0], [40.0, 40.0], [5.0, 40.0]]

[vehicle]
speed_mps = 3.0
start_xy_m = [5.0, 5.0]

[sensor]
sigma_bearing_deg = 1.0

[filters]
names = ["ekf", "srckf"]
"""


def write(tmp_path: Path, text: str, name: str = "w.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_minimal_world_gets_bailey_defaults(tmp_path: Path) -> None:
    w = load_world(write(tmp_path, GOOD))
    assert w.name == "w" and w.seed == 0 and w.paper == {}
    assert w.vehicle.loops == 2 and w.vehicle.dt_s == 0.025 and w.sensor.period_steps == 8
    assert math.isclose(w.noise.sigma_steer_rad, math.radians(3.0))
    assert w.filters.association == "known" and w.filters.mode == "joint"
    assert w.vehicle.initial_pose_sigma == (0.0, 0.0, 0.0)
    assert math.isclose(w.vehicle.start[2], 0.0)  # towards (40, 5) from (5, 5)


def test_map_file_next_to_the_world(tmp_path: Path) -> None:
    (tmp_path / "maps").mkdir()
    (tmp_path / "maps" / "m.json").write_text(
        json.dumps({"lm": [[10.0, 20.0], [10.0, 30.0]], "wp": [[40.0, 40.0], [5.0, 40.0]]})
    )
    text = GOOD.replace(
        "landmarks = [[10.0, 10.0], [40.0, 40.0]]\n"
        "waypoints = [[40.0, 5.0], [40.0, 40.0], [5.0, 40.0]]",
        'file = "maps/m.json"',
    )
    w = load_world(write(tmp_path, text))
    assert np.array_equal(w.map.landmarks, [[10.0, 10.0], [20.0, 30.0]])
    assert np.array_equal(w.map.waypoints, [[40.0, 5.0], [40.0, 40.0]])


LANDMARKS = "landmarks = [[10.0, 10.0], [40.0, 40.0]]"
WAYPOINTS = "waypoints = [[40.0, 5.0], [40.0, 40.0], [5.0, 40.0]]"

# (id, old text, new text, dotted key or None, text the message must contain)
# fmt: off
FAULTS = [
    ("unknown-key", "speed_mps = 3.0", "speed_mps = 3.0\nsped_mps = 3.0", "vehicle.sped_mps",
     "unknown key"),
    ("unknown-section", "[sensor]", "[sensr]", "sensr", "unknown key"),
    ("missing-key", "runs = 3\n", "", "runs", "missing"),
    ("missing-section", '[filters]\nnames = ["ekf", "srckf"]\n', "", "filters", "missing"),
    ("wrong-type", "speed_mps = 3.0", 'speed_mps = "fast"', "vehicle.speed_mps",
     "must be a number"),
    ("bool-for-number", "speed_mps = 3.0", "speed_mps = true", "vehicle.speed_mps",
     "must be a number"),
    ("negative-speed", "speed_mps = 3.0", "speed_mps = -3.0", "vehicle.speed_mps",
     "[vehicle] speed_mps = -3.0: must be in (0, 50]"),
    ("sigma-out-of-range", "sigma_bearing_deg = 1.0", "sigma_bearing_deg = 90.0",
     "sensor.sigma_bearing_deg", "must be in (0, 45]"),
    ("nan", "sigma_bearing_deg = 1.0", "sigma_bearing_deg = nan", "sensor.sigma_bearing_deg",
     "must be in (0, 45]"),
    ("runs-zero", "runs = 3", "runs = 0", "runs", "runs = 0: must be an integer in [1, 100000]"),
    ("float-for-int", "runs = 3", "runs = 2.5", "runs", "must be an integer"),
    ("waypoint-outside", WAYPOINTS, "waypoints = [[40.0, 5.0], [130.0, 40.0]]",
     "map.waypoints[1]", "outside the map bounds_m"),
    ("landmark-outside", LANDMARKS, "landmarks = [[-1.0, 10.0]]", "map.landmarks[0]",
     "outside the map bounds_m"),
    ("start-outside", "start_xy_m = [5.0, 5.0]", "start_xy_m = [5.0, 55.0]",
     "vehicle.start_xy_m", "outside the map bounds_m"),
    ("too-few-waypoints", WAYPOINTS, "waypoints = [[40.0, 5.0]]", "map.waypoints",
     "at least 2 waypoints"),
    ("no-landmarks-anywhere", LANDMARKS + "\n", "", "map.landmarks", "missing"),
    ("bad-pair", LANDMARKS, "landmarks = [[10.0, 10.0], [40.0]]", "map.landmarks[1]",
     "[x, y] pair"),
    ("unknown-filter", 'names = ["ekf", "srckf"]', 'names = ["ekf", "kalman"]',
     "filters.names[1]", "srcdkf"),
    ("repeated-filter", 'names = ["ekf", "srckf"]', 'names = ["ekf", "ekf"]', "filters.names",
     "repeat"),
    ("bad-association", 'names = ["ekf", "srckf"]', 'names = ["ekf"]\nassociation = "jcbb"',
     "filters.association", "'known', 'nn'"),
    ("gates-crossed", 'names = ["ekf", "srckf"]', 'names = ["ekf"]\ngate_new = 2.0',
     "filters.gate_new", ">= gate_accept"),
    ("bounds-reversed", "bounds_m = [0.0, 50.0, 0.0, 50.0]", "bounds_m = [50.0, 0.0, 0.0, 50.0]",
     "map.bounds_m", "min < max"),
    ("unknown-kind", 'kind = "planar-slam"', 'kind = "submarine"', "kind", "unknown kind"),
    ("missing-map-file", LANDMARKS + "\n" + WAYPOINTS, 'file = "nope.json"', "map.file",
     "not found"),
    ("multi-line-description", 'description = "tiny"', 'description = """a\nb"""',
     "description", "one non-empty line"),
    ("paper-datetime", "runs = 3", "runs = 3\n[paper]\nwhen = 2020-01-01", "paper.when",
     "must be a string, number"),
]
# fmt: on


@pytest.mark.parametrize(
    ("old", "new", "key", "fragment"), [f[1:] for f in FAULTS], ids=[f[0] for f in FAULTS]
)
def test_malformed_world_is_refused(
    tmp_path: Path, old: str, new: str, key: str, fragment: str
) -> None:
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new, 1))
    with pytest.raises(WorldError) as info:
        load_world(path)
    err = info.value
    assert err.file == str(path) and err.key == key
    text = str(err)
    assert text.startswith(f"{path}: ")
    head, _, last = key.rpartition(".")
    assert (f"[{head}] {last}" if head else last) in text
    assert fragment in text


def test_map_file_contents_checked(tmp_path: Path) -> None:
    (tmp_path / "m.json").write_text(json.dumps({"lm": [[1.0, 2.0], [1.0]], "wp": []}))
    text = GOOD.replace(LANDMARKS + "\n" + WAYPOINTS, 'file = "m.json"')
    with pytest.raises(WorldError, match=r"\[map\] file = \"m.json\": \"lm\" must be"):
        load_world(write(tmp_path, text))


def test_inline_and_file_both_given(tmp_path: Path) -> None:
    (tmp_path / "m.json").write_text(json.dumps({"lm": [[10.0], [10.0]]}))
    text = GOOD.replace(WAYPOINTS, WAYPOINTS + '\nfile = "m.json"')
    with pytest.raises(WorldError) as info:
        load_world(write(tmp_path, text))
    assert info.value.key == "map.landmarks" and "both inline and in map file" in str(info.value)


def test_small_world_is_validated() -> None:
    w = small_world(vehicle={"loops": 2})
    assert w.vehicle.loops == 2 and w.map.landmarks.shape == (4, 2)
    with pytest.raises(WorldError, match=r"<small>: \[vehicle\] loops = 0"):
        small_world(vehicle={"loops": 0})
