"""Alignment world files (:mod:`slam.kinds.alignment.world`): the bundled worlds hold
[Wu-Wang 2014] §4's numbers, and malformed worlds are refused naming the file, the key and
the rule (through the command line: exit code 2, nothing written)."""

from __future__ import annotations

import math
from importlib.resources import files

import pytest
from click.testing import CliRunner

import slam.cli
from nav.strapdown import G0
from slam.kinds.alignment.world import AlignmentWorld
from slam.registry import list_worlds, load_world, world_from_dict
from tests.slam.kinds.alignment.worlds import alignment_doc
from worlds import WorldError

DEG = math.pi / 180.0


def test_bundled_worlds_hold_the_papers_numbers() -> None:
    w = load_world("alignment")
    assert isinstance(w, AlignmentWorld) and w.runs == 50 and w.duration_s == 200.0
    s = w.sway
    assert (s.elevation_rad, s.elevation_amplitude_rad, s.elevation_frequency_hz) == (
        pytest.approx(45 * DEG), pytest.approx(5 * DEG), 2.0)
    assert (s.roll_rad, s.roll_amplitude_rad, s.roll_frequency_hz) == (
        0.0, pytest.approx(3 * DEG), 10.0)
    m = w.imu
    assert m.rate_hz == 1000.0 and w.filters.rate_hz == 10.0 and w.filters.gamma == 5.0
    assert m.gyro_bias_rad_s == m.gyro_white_rad_s == m.gyro_markov_rad_s == pytest.approx(
        0.01 * DEG)
    assert (m.gyro_markov_tau_s, m.accel_markov_tau_s) == (3600.0, 1800.0)
    assert m.accel_bias_mps2 == m.accel_white_mps2 == pytest.approx(1e-4 * G0)
    assert w.wind.mean_mps == (2.0, 2.7) and w.wind.frequency_hz == (1.0, 0.5, 0.25)
    assert w.wind.amplitude_x_mps == (0.15, 0.2, 0.5)
    assert w.wind.amplitude_y_mps == (0.15, 0.2, 0.3)
    assert set(w.filters.names) == {"ukf", "uthinf", "srckf", "srchinf", "ekf"}
    assert (w.samples_per_epoch, w.n_epochs, w.epochs_per_key) == (100, 2001, 10)
    calm = load_world("alignment-no-lf-wind")
    assert calm.wind.amplitude_x_mps[2] == calm.wind.amplitude_y_mps[2] == 0.0
    assert calm.wind.amplitude_x_mps[:2] == w.wind.amplitude_x_mps[:2]
    assert {("alignment", "alignment"), ("alignment-no-lf-wind", "alignment")} <= {
        (n, k) for n, k, _ in list_worlds()}


BAD = [
    ({"filters.rate_hz": 3.0}, "filters.rate_hz", "whole number"),
    ({"duration_s": 200.05}, "duration_s", "whole number"),
    ({"reference.key_interval_s": 0.15}, "reference.key_interval_s", "whole number"),
    ({"duration_s": 2.0, "reference.key_interval_s": 5.0}, "reference.key_interval_s",
     "must not exceed"),
    ({"filters.names": ["ukf", "kalman"]}, "filters.names[1]", "uthinf"),
    ({"sway.roll_amplitude_deg": 60.0}, "sway.roll_amplitude_deg", "[0, 45]"),
    ({"wind.amplitude_x_mps": [0.1, 0.2]}, "wind.amplitude_x_mps", "3 numbers"),
    ({"imu.gyro_drift_deg_s": 0.01}, "imu.gyro_drift_deg_s", "unknown key"),
    ({"site.latitude_deg": "32"}, "site.latitude_deg", "number"),
    ({"filters.velocity_sigma_mps": 0.0}, "filters.velocity_sigma_mps", "(0, 10]"),
]


@pytest.mark.parametrize(("overrides", "key", "rule"), BAD)
def test_a_malformed_world_names_file_key_and_rule(overrides, key, rule) -> None:
    with pytest.raises(WorldError) as info:
        world_from_dict(alignment_doc(**overrides), name="bad", source="bad.toml")
    assert info.value.key == key and str(info.value).startswith("bad.toml: "), str(info.value)
    assert rule in str(info.value)


def test_the_command_line_refuses_a_malformed_world_and_writes_nothing(tmp_path) -> None:
    text = (files("worlds") / "alignment.toml").read_text(encoding="utf-8")
    assert text.count("\ngamma = 5.0\n") == 1
    path = tmp_path / "bad.toml"
    path.write_text(text.replace("\ngamma = 5.0\n", "\ngamma = -1.0\n"), encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(path), "--out", str(out)])
    assert res.exit_code == 2 and "[filters.hinf] gamma = -1.0" in res.output, res.output
    assert not out.exists()


def test_the_h_infinity_filters_are_the_kinds_filters() -> None:
    from slam.registry import get_kind

    assert {"uthinf", "srchinf", "ukf", "ekf"} <= set(get_kind("alignment").filters)
