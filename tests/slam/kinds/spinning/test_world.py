"""``spinning`` world files (:mod:`slam.kinds.spinning.world`): the bundled world, and
malformed worlds naming the key and the file."""

from __future__ import annotations

import math
from importlib.resources import files
from pathlib import Path

import pytest

from slam.kinds.spinning.world import SpinningWorld
from slam.registry import load_world
from tests.slam.kinds.spinning.helpers import spinning_world
from worlds import WorldError

DEG = math.pi / 180.0


def test_bundled_world_loads() -> None:
    w = load_world("spinning")
    assert isinstance(w, SpinningWorld) and w.kind == "spinning" and w.runs == 50
    assert w.sample_interval_s == 0.1 and w.flight.speed_mps == 897.0
    assert math.isclose(w.flight.pitch_rad, 45 * DEG) and w.flight.drag_k_per_m is None
    assert (w.flight.target_flight_time_s, w.flight.target_range_m,
            w.flight.target_apex_m) == (87.5, 27126.4, 9377.0)
    assert math.isclose(w.field.inclination_rad, -48.17 * DEG)
    assert math.isclose(w.field.declination_rad, 2.32 * DEG)
    assert w.field.intensity_nt == 50986.1
    assert set(w.filters.names) == {"ukf", "ckf", "srckf", "svdckf", "srchinf", "uthinf", "ekf"}
    assert w.sweep.factors == (1.0, 2.0, 5.0, 10.0) and math.isinf(w.sweep.gammas_rad[-1])
    assert w.filters.mode == "joint" and "600-800 s" in w.paper["blind_area"]
    assert w.sweep.scales == ("both", "gyro", "magnetometer")
    assert w.filters.unscented == {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"}
    assert w.filters.gamma_rad == w.filters.hinf["gamma"] and w.filters.on_failure == "kalman"
    assert w.sweep.tasks <= w.runs  # every sweep log is computed by a campaign run
    hard = load_world("spinning-large-error")  # the paper's system, larger launch errors
    assert hard.filters.initial_sigma_rad == pytest.approx((3 * DEG, 8 * DEG))
    assert (hard.flight, hard.field, hard.gyro) == (w.flight, w.field, w.gyro)
    assert hard.filters.gamma_rad == 2.0 and hard.sweep.tasks <= hard.runs
    tails = load_world("spinning-outliers")
    assert tails.truth_noise.distribution == "contaminated"
    assert tails.sweep.distributions == ("student-t", "contaminated")
    assert tails.flight == w.flight and tails.field == w.field


@pytest.mark.parametrize(
    ("overrides", "key"),
    [
        ({"launch.pitch_deg": 95.0}, "launch.pitch_deg"),
        ({"spin.rate_rev_s": -1.0}, "spin.rate_rev_s"),
        ({"field.inclination_deg": "down"}, "field.inclination_deg"),
        ({"truth_noise.distribution": "cauchy"}, "truth_noise.distribution"),
        ({"truth_noise.student_t_dof": 2.0}, "truth_noise.student_t_dof"),
        ({"filters.names": ["srckf", "kalman"]}, "filters.names[1]"),
        ({"filters.hinf.on_failure": "ignore"}, "filters.hinf.on_failure"),
        ({"filters.hinf.gamma": 0.0}, "filters.hinf.gamma"),
        ({"filters.gamma_rad": 2.0}, "filters.gamma_rad"),  # moved to [filters.hinf]
        ({"filters.unscented": None, "sweep.filters": ["srckf"]}, "filters.unscented"),
        ({"sweep.scales": ["both", "accelerometer"]}, "sweep.scales[1]"),
        ({"filters.initial_sigma_deg": [1.0]}, "filters.initial_sigma_deg"),
        ({"sweep.gammas_rad": [2.0, -1.0]}, "sweep.gammas_rad[1]"),
        ({"sweep.factors": [0.5]}, "sweep.factors[0]"),
        ({"magnetometer.noise_mT": 1.0}, "magnetometer.noise_mT"),  # misspelt key
        ({"sample_interval_s": 0.0}, "sample_interval_s"),
    ],
)
def test_malformed_world_names_the_key(overrides: dict, key: str) -> None:
    with pytest.raises(WorldError) as info:
        spinning_world(**overrides)
    assert info.value.key == key


def test_malformed_world_file_names_the_file(tmp_path: Path) -> None:
    text = (files("worlds") / "spinning.toml").read_text(encoding="utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("noise_nt = 100.0", "noise_nt = -100.0"), encoding="utf-8")
    with pytest.raises(WorldError) as info:
        load_world(bad)
    assert info.value.key == "magnetometer.noise_nt" and str(bad) in str(info.value)
    start = text.index("[field]")
    missing = tmp_path / "missing.toml"
    missing.write_text(text[:start] + text[text.index("[gyro]"):], encoding="utf-8")
    with pytest.raises(WorldError, match=r"field.*missing section"):
        load_world(missing)
