"""Ship world files (:mod:`slam.kinds.ship.world`): the bundled world holds [Ding 2017]'s
Table 1, and malformed worlds are refused naming the file, the key and the rule (through
the command line: exit code 2, nothing written)."""

from __future__ import annotations

import dataclasses
import math
from importlib.resources import files

import pytest
from click.testing import CliRunner

import slam.cli
from slam.kinds.ship.world import ShipWorld
from slam.registry import list_worlds, load_world, world_from_dict
from tests.slam.kinds.ship.worlds import ship_doc
from worlds import WorldError

DEG = math.pi / 180.0
DEG_H = DEG / 3600.0


def test_bundled_ship_world_holds_the_papers_table_1() -> None:
    w = load_world("ship")
    assert isinstance(w, ShipWorld) and w.kind == "ship" and w.runs == 50
    assert (w.site.latitude_rad, w.site.longitude_rad, w.site.height_m) == (
        pytest.approx(45 * DEG), pytest.approx(126 * DEG), 0.0)
    assert w.duration_s == 300.0 and w.gyro.rate_hz == 100.0
    assert w.gyro.arw_rad_sqrt_s == pytest.approx(0.04 * DEG / 60.0)
    assert w.gyro.bias_rw_rad_s_sqrt_s == pytest.approx(0.005 * DEG_H / 60.0)
    assert w.gyro.bias_rad_s == pytest.approx((DEG_H,) * 3)
    assert w.filters.initial_error_rad == pytest.approx((2 * DEG, 4 * DEG, 15 * DEG))
    assert {"hommukf", "ukf", "cdkf", "srckf", "ekf"} <= set(w.filters.names)
    assert [w.filters.treatment(n) for n in ("hommukf", "ukf", "cdkf", "srckf", "ekf")] == [
        "paper", "paper", "paper", "manifold", "manifold"]
    assert ("ukf", "additive") in w.filters.variants
    assert (w.samples_per_update, w.n_updates) == (100, 301)
    assert w.paper["claims"]["ukf"]["yaw_within_arcmin"] == 40.0
    assert ("ship", "ship") in {(n, k) for n, k, _ in list_worlds()}


BAD = [
    ({"vectors.rate_hz": 3.0}, "vectors.rate_hz", "whole number"),
    ({"filters.variants": ["ukf:quaternion"]}, "filters.variants[0]", "unknown treatment"),
    ({"filters.variants": ["kalman:paper"]}, "filters.variants[0]", "unknown filter"),
    ({"filters.variants": ["ukf:paper", "ukf:paper"]}, "filters.variants", "repeat"),
    ({"filters.paper_model": ["srukf"]}, "filters.paper_model", "names"),
    ({"waves.roll_amplitude_deg": 60.0}, "waves.roll_amplitude_deg", "[0, 45]"),
    ({"gyro.arw_deg_sqrt_hr": 0.04}, "gyro.arw_deg_sqrt_hr", "unknown key"),
    ({"site.latitude_deg": "45"}, "site.latitude_deg", "number"),
    ({"duration_s": 300.5}, "duration_s", "whole number"),
    ({"scoring.steady_state_from_s": 300.0}, "scoring.steady_state_from_s", "below"),
    ({"filters.initial_error_deg": [2.0, 4.0]}, "filters.initial_error_deg", "3 numbers"),
    ({"vectors.gravity_sigma_mg": 0.0}, "vectors.gravity_sigma_mg", "(0, 500]"),
    ({"filters.homm.moments": "adaptive"}, "filters.homm.moments", "'fixed', 'predicted'"),
    ({"filters.homm": {"skewness": 0.0, "kurtosis": 3.0}}, "filters.homm.moments", "missing"),
    ({"filters.unscented.kappa": "3"}, "filters.unscented.kappa", '"3-n"'),
]


@pytest.mark.parametrize("table", ["unscented", "central_difference", "homm"])
def test_every_filter_setting_is_stated(table) -> None:
    """A world whose filters (or variants) take a settings table must state it."""
    doc = ship_doc()
    del doc["filters"][table]
    with pytest.raises(WorldError) as info:
        world_from_dict(doc, name="bad", source="bad.toml")
    assert info.value.key == f"filters.{table}" and "missing (required by" in str(info.value)
    if table == "unscented":
        assert "ukf, ukf:additive, ukf:manifold" in str(info.value)


def test_the_worlds_state_their_settings_and_the_harder_one_only_its_initial_error() -> None:
    paper, hard = load_world("ship"), load_world("ship-large-error")
    assert paper.filters.settings_of("ukf") == {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"}
    assert paper.filters.settings_of("hommukf") == {"moments": "predicted", "skewness": 0.0,
                                                    "kurtosis": 3.0}
    assert paper.filters.make("cdkf").rule.h == pytest.approx(math.sqrt(3.0))
    assert hard.filters.initial_error_rad == pytest.approx((10 * DEG, 10 * DEG, 45 * DEG))
    assert hard.filters.initial_attitude_sigma_rad == hard.filters.initial_error_rad
    same = dataclasses.replace(hard, name=paper.name, description=paper.description,
                               source=paper.source,
                               filters=dataclasses.replace(
                                   hard.filters,
                                   initial_error_rad=paper.filters.initial_error_rad,
                                   initial_attitude_sigma_rad=(
                                       paper.filters.initial_attitude_sigma_rad)))
    assert same == paper


@pytest.mark.parametrize(("overrides", "key", "rule"), BAD)
def test_a_malformed_world_names_file_key_and_rule(overrides, key, rule) -> None:
    with pytest.raises(WorldError) as info:
        world_from_dict(ship_doc(**overrides), name="bad", source="bad.toml")
    assert info.value.key == key and str(info.value).startswith("bad.toml: "), str(info.value)
    assert rule in str(info.value)


def test_the_command_line_refuses_a_malformed_world_and_writes_nothing(tmp_path) -> None:
    text = (files("worlds") / "ship.toml").read_text(encoding="utf-8")
    assert text.count("\nrate_hz = 1.0\n") == 1
    path = tmp_path / "bad.toml"
    path.write_text(text.replace("\nrate_hz = 1.0\n", "\nrate_hz = 0.0\n"), encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(path), "--out", str(out)])
    assert res.exit_code == 2 and "[vectors] rate_hz = 0.0" in res.output
    assert not out.exists()
