"""Hostile world files are refused before anything runs (:mod:`worlds.limits`, the loader
and the kinds' size checks): derived sizes over their stated limits, deep nesting, files
that are not regular files, huge integers - each a :class:`WorldError` naming the key."""

from __future__ import annotations

import tomllib
from importlib.resources import files

import pytest
from click.testing import CliRunner

import slam.cli
from slam.registry import KINDS, load_world, world_from_dict
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


def bundled(name: str, **dotted) -> dict:
    """The bundled world ``name`` as a document with dotted-key overrides."""
    doc = tomllib.loads((files("worlds") / f"{name}.toml").read_text(encoding="utf-8"))
    return overridden(doc, dotted)


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
    (bundled("fixed-wing", **{"duration_s": 7200.0, "imu.rate_hz": 1000.0}), "[imu] rate_hz",
     "IMU samples"),
])
def test_derived_sizes_over_their_limits_are_refused(doc, key, size):
    with pytest.raises(WorldError, match="at most") as err:
        world_from_dict(doc)
    assert key in str(err.value) and size in str(err.value)


# The kinds that had no size check on ed14704 (issue 24): each world below allocated
# gigabytes or ran for hours before failing; now the registry refuses it on load with the
# key, the world's figure and the limit.
@pytest.mark.parametrize(("doc", "message"), [
    (bundled("ship", **{"duration_s": 86_400.0, "gyro.rate_hz": 10_000.0}),
     "[gyro] rate_hz = 10000.0: the run would need 8.6e+08 gyro samples (duration_s = 86400 "
     "at 10000 Hz); at most 250,000 are allowed"),
    (bundled("alignment", **{"duration_s": 3600.0, "imu.rate_hz": 10_000.0}),
     "[imu] rate_hz = 10000.0: the run would need 3.6e+07 IMU samples (duration_s = 3600 at "
     "10000 Hz); at most 250,000 are allowed"),
    (bundled("alignment", **{"duration_s": 2000.0, "imu.rate_hz": 100.0,
                             "filters.rate_hz": 100.0}),
     "[filters] rate_hz = 100.0: the run would need 200,001 filter epochs (duration_s = 2000 "
     "at 100 Hz); at most 50,000 are allowed"),
    (bundled("spinning", sample_interval_s=0.001),
     "sample_interval_s = 0.001: the run would need 1,000,001 gyro and magnetometer samples "
     "(a flight of up to 1000 s with the calibrated drag, at sample_interval_s = 0.001); at "
     "most 250,000 are allowed"),
])
def test_alignment_ship_and_spinning_sizes_are_bounded_on_load(doc, message):
    with pytest.raises(WorldError) as err:
        world_from_dict(doc, source="w.toml")
    assert str(err.value) == f"w.toml: {message}"


def test_a_spinning_flight_bound_follows_the_launch():
    """With a stated drag the flight-time bound is the launch's, far below the integrator's
    horizon: a 1 ms sampling of a short, slow flight is allowed, of a long one refused."""
    from slam.kinds.spinning.world import flight_time_bound

    slow = bundled("spinning", sample_interval_s=0.001,
                   launch={"speed_mps": 100.0, "pitch_deg": 45.0, "yaw_deg": 0.0,
                           "roll_deg": 0.0}, **{"flight.drag_k_per_m": 1e-4})
    w = world_from_dict(slow)
    assert 14.4 < flight_time_bound(w.flight) < 60.0  # vacuum: 2 v sin(45°) / g = 14.4 s
    no_drag = bundled("spinning", **{"flight.drag_k_per_m": 0.0})
    assert flight_time_bound(world_from_dict(no_drag).flight) == pytest.approx(
        2 * 897.0 * 0.5**0.5 / 9.80665)
    with pytest.raises(WorldError, match="sample_interval_s = 0.001: .*up to 129.4 s"):
        world_from_dict({**no_drag, "sample_interval_s": 0.001})


def test_the_bundled_worlds_are_well_within_the_limits():
    for name in ("bailey", "bailey-sparse", "densemap", "webmap", "drone", "drone-hills",
                 "drone-large-yaw",
                 "star-sensor", "star-sensor-hard", "ship", "ship-large-error", "alignment",
                 "alignment-strong-wind", "spinning", "spinning-large-error", "fixed-wing",
                 "fixed-wing-sparse-gnss"):
        load_world(name)


def test_every_registered_kind_declares_its_work():
    for kind in KINDS.values():
        assert callable(kind.work), kind.name


def test_a_mode_given_on_the_command_line_is_checked_too(tmp_path):
    """Local mode keeps the filter work of 600 mapped landmarks small; ``--mode joint``
    multiplies it past the limit and is refused before anything runs."""
    lms = [[float(x), float(y)] for x in range(0, 30, 1) for y in (-2.0, 2.0)] * 10
    doc = _with(PLANAR, map__landmarks=[[x + 0.01 * i, y] for i, (x, y) in enumerate(lms)],
                filters__mode="local")
    world_from_dict(doc)
    path = tmp_path / "w.toml"
    path.write_text(_toml(doc), encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(path), "--mode", "joint", "--out",
                                             str(out)])
    assert res.exit_code == 2, res.output
    assert res.output.startswith(f"error: --mode joint: {path}: [filters] mode: the run would "
                                 "need ")
    assert "units of filter work" in res.output and "joint mode); at most 2e+11" in res.output
    assert not out.exists()


def _toml(doc: dict) -> str:
    """A small document of tables, lists and scalars as TOML text."""
    import json

    def value(v):
        return json.dumps(v)

    lines = [f"{k} = {value(v)}" for k, v in doc.items() if not isinstance(v, dict)]
    for k, v in doc.items():
        if isinstance(v, dict):
            lines.append(f"[{k}]")
            lines += [f"{kk} = {value(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


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
    with pytest.raises(WorldError, match=r"w\.toml(:1)?: (invalid TOML|.*nested deeper|a "
                                         r"dotted key or table header of 5,000 parts)"):
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
