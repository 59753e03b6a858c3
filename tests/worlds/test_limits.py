"""Hostile world files are refused before anything runs (:mod:`worlds.limits`, the loader
and the kinds' size checks): derived sizes over their stated limits, deep nesting, files
that are not regular files, huge integers - each a :class:`WorldError` naming the key."""

from __future__ import annotations

import pytest

from slam.registry import load_world, world_from_dict
from tests.small_worlds import overridden, small_drone_doc, star_sensor_doc
from worlds import WorldError, limits
from worlds.loader import parse_toml

PLANAR = {
    "kind": "planar-slam", "description": "limits", "runs": 1,
    "map": {"bounds_m": [-20.0, 50.0, -20.0, 50.0], "landmarks": [[15.0, -6.0]],
            "waypoints": [[30.0, 0.0], [30.0, 30.0]]},
    "vehicle": {"start_xy_m": [0.0, 0.0]}, "filters": {"names": ["ekf"]},
}


SPEED = "[vehicle] speed_mps"


def _with(doc: dict, **dotted) -> dict:
    """``doc`` with ``section__key=value`` overrides."""
    return overridden(doc, {k.replace("__", "."): v for k, v in dotted.items()})


@pytest.mark.parametrize(("doc", "key", "size"), [
    (_with(PLANAR, vehicle__speed_mps=1e-300), SPEED, "control steps"),
    (_with(PLANAR, vehicle__dt_s=1e-308), SPEED, "control steps"),
    (_with(PLANAR, vehicle__loops=100, vehicle__speed_mps=0.01), SPEED, "control steps"),
    (_with(PLANAR, sensor__period_steps=100_000), "[filters] mode", "filter work"),
    (_with(PLANAR, map__landmarks=[[float(i % 50), 1.0] for i in range(2000)],
           sensor__max_range_m=1e4), "[map] landmarks", "state dimensions"),
    (_with(small_drone_doc(), imu__rate_hz=10_000.0, vehicle__loops=10), SPEED,
     "IMU samples"),
    (_with(small_drone_doc(), terrain__grid_spacing_m=0.1, terrain__margin_m=1e4),
     "[terrain] grid_spacing_m", "terrain grid vertices"),
    (star_sensor_doc(**{"star_sensor.rate_hz": 10.0, "gyro.rate_hz": 10_000.0,
                        "duration_s": 86_400.0}), "[gyro] rate_hz", "gyro samples"),
])
def test_derived_sizes_over_their_limits_are_refused(doc, key, size):
    with pytest.raises(WorldError, match="at most") as err:
        world_from_dict(doc)
    assert key in str(err.value) and size in str(err.value)


def test_the_bundled_worlds_are_well_within_the_limits():
    for name in ("bailey", "densemap", "webmap", "drone", "drone-hills", "star-sensor"):
        load_world(name)


def test_a_drone_altitude_smoothing_shorter_than_an_imu_period_is_refused():
    with pytest.raises(WorldError, match="altitude_smoothing_s.*one IMU period"):
        world_from_dict(_with(small_drone_doc(), vehicle__altitude_smoothing_s=1e-308))


@pytest.mark.parametrize("text", [
    "x = " + "[" * 1000 + "0" + "]" * 1000,
    "x = " + "{a = " * 700 + "0" + "}" * 700,
    "[" + ".".join(["deep"] * 5000) + "]\nx = 1",
    "x = " + "1" * 5000,
])
def test_deep_nesting_and_huge_integers_are_toml_errors(text):
    with pytest.raises(WorldError, match=r"w\.toml: invalid TOML|nested deeper"):
        parse_toml(text.encode(), "w.toml")
    deep: list = [0]
    for _ in range(40):
        deep = [deep]
    with pytest.raises(WorldError, match="nested deeper than 32"):
        world_from_dict({**PLANAR, "paper": {"a": deep}})


def test_referenced_files_must_be_small_regular_files(tmp_path):
    doc = _with(PLANAR)
    del doc["map"]["landmarks"], doc["map"]["waypoints"]
    for target, why in (("/dev/zero", "not a regular file"), (".", "not a regular file"),
                        ("missing.json", "file not found")):
        doc["map"]["file"] = target
        with pytest.raises(WorldError, match=why):
            world_from_dict(doc, source="w.toml", base=tmp_path)
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    doc["map"]["file"] = "deep.json"
    with pytest.raises(WorldError, match="nested too deeply"):
        world_from_dict(doc, source="w.toml", base=tmp_path)
    with pytest.raises(WorldError, match="not a regular file"):
        load_world(str(tmp_path))
    assert limits.MAX_FILE_BYTES >= 1 << 20
