"""Fixed-wing world files: the bundled world and its truth meet the paper's set-up, and
malformed worlds are refused naming the file, the key and the rule (CLI: exit code 2)."""

from __future__ import annotations

import math
from importlib.resources import files

import numpy as np
import pytest
from click.testing import CliRunner

import slam.cli
from nav.euler import q_to_euler_zyx
from slam.kinds.fixed_wing.simulate import truth_of
from slam.kinds.fixed_wing.world import FixedWingWorld
from slam.registry import list_worlds, load_world, world_from_dict
from tests.slam.kinds.fixed_wing.worlds import fw_doc
from worlds import WorldError

DEG = math.pi / 180.0


def test_bundled_world_and_its_flight_meet_the_papers_setup() -> None:
    w = load_world("fixed-wing")
    assert isinstance(w, FixedWingWorld) and w.runs == 15 and w.duration_s == 500.0
    assert w.imu.rate_hz == 100.0 and w.gnss.rate_hz == 1.0
    assert w.paper["table1"]["ckf"]["heading_deg"] == 0.9
    assert ("fixed-wing", "fixed-wing") in {(n, k) for n, k, _ in list_worlds()}
    tr = truth_of(w)
    assert tr.n_samples * tr.dt == pytest.approx(500.0, rel=0.02)
    speed = np.linalg.norm(tr.v, axis=1)
    assert 19.99 < speed.min() and speed.max() < 30.01 and speed.max() > 29.0
    bank = np.abs(q_to_euler_zyx(tr.q)[:, 0])
    assert bank.max() <= 30.0 * DEG and bank.max() > 20.0 * DEG  # banked turns, <= 30°
    assert tr.v[0, 2] > 0.0 and tr.p[3000, 2] > tr.p[0, 2] + 50.0  # take-off climb
    turning = np.abs(tr.turn_rate) > DEG
    assert np.sum(np.diff(turning.astype(int)) == 1) == 5  # five coordinated turns
    climb = tr.v[:, 2] / speed
    assert climb.min() < -0.09 and climb[20000:].max() > 0.09  # a descent and a later climb


@pytest.mark.parametrize("change, key, message", [
    ({"imu.rate_hz": 5.0}, "imu.rate_hz", "must be in [10, 1000]"),
    ({"gnss.rate_hz": 3.0}, "gnss.rate_hz", "must divide the IMU rate"),
    ({"flight.climb_deg": [0.0]}, "flight.climb_deg", "as many entries"),
    ({"flight.manoeuvre_start_s": [30.0, 31.0] + [100.0 + 20 * i for i in range(13)]},
     "flight.manoeuvre_start_s[1]", "must not start before manoeuvre 0 ends"),
    ({"filters.names": ["ea-ukf", "ins-hommukf"]}, "filters.names[1]", "unknown"),
    ({"duration_s": 10_000.0}, "duration_s", "must be in (0, 7200]"),
    ({"ea.roll_pitch_sigma_deg": -1.0}, "ea.roll_pitch_sigma_deg", "must be in (0, 90]"),
    ({"duration_s": 501.0, "ea.update_rate_hz": 0.4}, "duration_s",
     "must be a whole number of EA periods (2.5 s)"),  # was a reshape ValueError in the run
])
def test_world_errors_name_the_key(change, key, message) -> None:
    with pytest.raises(WorldError) as err:
        world_from_dict(fw_doc(**change), source="bad.toml")
    assert err.value.key == key and message in str(err.value), str(err.value)


def test_command_line_refuses_a_bad_world_with_exit_2(tmp_path) -> None:
    text = (files("worlds") / "fixed-wing.toml").read_text(encoding="utf-8")
    old = "velocity_sigma_mps = 0.1"
    assert text.count(old) == 1
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, "velocity_sigma_mps = 0.0"), encoding="utf-8")
    res = CliRunner().invoke(slam.cli.main, ["run", str(path), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    assert "bad.toml" in res.output and "[gnss] velocity_sigma_mps = 0.0" in res.output
    assert "(0, 100]" in res.output and not (tmp_path / "o").exists()
