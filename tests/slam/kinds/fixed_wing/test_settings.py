"""The fixed-wing filters' stated settings: the bundled worlds' UKF is Julier's κ = 3 − n
set (not the cubature one) and, on a short flight with the harder world's 45° heading
prior, the INS-UKF and INS-CKF estimates differ; a world that runs a UKF without
``[filters.unscented]`` is refused naming the key and the filters; the harder world is the
paper's world with only the GNSS rate and the heading priors changed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.kinds.fixed_wing import run as fr
from slam.kinds.fixed_wing.simulate import simulate
from slam.registry import load_world, read_world, world_from_dict
from tests.slam.kinds.fixed_wing.worlds import fw_doc, short_world
from worlds import WorldError


@pytest.mark.parametrize("name", ["fixed-wing", "fixed-wing-sparse-gnss"])
def test_the_bundled_ukf_is_juliers_set(name) -> None:
    fs = load_world(name).filters
    assert fs.unscented == {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"}
    for f in ("ea-ukf", "ins-ukf"):
        assert not fs.make(f).rule.cubature_equivalent
        assert fs.describe(f) == "α = 1, β = 0, κ = 3 − n"


def test_the_ins_ukf_and_ckf_differ_on_a_short_flight() -> None:
    w = short_world(**{"ins.initial_attitude_sigma_deg": [1.0, 1.0, 45.0]})
    rng = np.random.default_rng(4)
    log = simulate(w, rng)
    x0, P0 = fr.ins_prior(log, rng)
    u, c = fr.run_ins(log, "ins-ukf", x0, P0), fr.run_ins(log, "ins-ckf", x0, P0)
    assert not u.diverged and not c.diverged
    assert np.max(np.abs(u.err_att[:, 2] - c.err_att[:, 2])) > math.radians(0.5)
    assert u.sig_pos is not None and u.sig_pos.shape == u.err_pos.shape
    assert np.all(u.sig_pos[1:] > 0) and np.all(u.sig_vel[1:] > 0)


def test_a_ukf_without_its_settings_is_refused() -> None:
    doc = fw_doc()
    del doc["filters"]["unscented"]
    with pytest.raises(WorldError) as info:
        world_from_dict(doc, name="bad", source="bad.toml")
    assert info.value.key == "filters.unscented" and "ea-ukf, ins-ukf" in str(info.value)
    doc["filters"]["names"] = ["ea-ckf", "ins-ckf"]
    assert world_from_dict(doc, name="ok").filters.unscented is None


def test_the_harder_world_changes_only_the_gnss_rate_and_heading_priors() -> None:
    paper, hard = read_world("fixed-wing").data, read_world("fixed-wing-sparse-gnss").data
    changed = {(s, k) for s in paper if isinstance(paper[s], dict)
               for k in paper[s] if paper[s][k] != hard[s].get(k)}
    assert changed == {("gnss", "rate_hz"), ("ea", "initial_sigma_deg"),
                       ("ins", "initial_attitude_sigma_deg")}
    assert hard["gnss"]["rate_hz"] == 0.1 and hard["ins"]["initial_attitude_sigma_deg"][2] == 45
