"""The alignment filters' stated settings and the H∞ γ sweep: the bundled worlds' UKF is
not the cubature set and differs from the cubature filter on the AQE model; a world that
runs a UKF-family filter without ``[filters.unscented]`` is refused; at a γ below the
azimuth's σ the existence check fails and every failure is counted (the Kalman update
taken), at γ = ∞ the sweep's UT-H∞ is its UKF twin run for run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.kinds.alignment.run import run_filter, run_once
from slam.kinds.alignment.simulate import simulate_alignment
from slam.kinds.alignment.summary import summarize
from slam.registry import load_world, world_from_dict
from tests.slam.kinds.alignment.worlds import alignment_doc, alignment_world
from worlds import WorldError


@pytest.mark.parametrize("name", ["alignment", "alignment-no-lf-wind", "alignment-strong-wind"])
def test_the_bundled_ukf_is_not_the_cubature_set(name) -> None:
    fs = load_world(name).filters
    assert fs.unscented == {"alpha": 1e-3, "beta": 2.0, "kappa": 0.0}
    assert not fs.make("ukf").rule.cubature_equivalent
    assert "cubature" not in fs.describe("uthinf") and "γ = 5" in fs.describe("uthinf")


def test_the_ukf_and_the_ckf_differ_on_the_aqe_model() -> None:
    world = alignment_world(2.0)
    log = simulate_alignment(world, np.random.default_rng(3))
    ukf, ckf = run_filter(world, log, "ukf"), run_filter(world, log, "srckf")
    # the points at +-0.0036 sigma (alpha = 1e-3) against +-3.6 sigma: the azimuth moves apart
    assert np.max(np.abs(ukf.err[:, 2] - ckf.err[:, 2])) > math.radians(1.0)


def test_a_ukf_without_its_settings_is_refused() -> None:
    doc = alignment_doc()
    del doc["filters"]["unscented"]
    with pytest.raises(WorldError) as info:
        world_from_dict(doc, name="bad", source="bad.toml")
    assert info.value.key == "filters.unscented" and "ukf, uthinf" in str(info.value)
    doc = alignment_doc(**{"filters.names": ["srckf", "ekf"], "sweep.filters": ["srchinf"]})
    del doc["filters"]["unscented"], doc["filters"]["hinf"]
    with pytest.raises(WorldError) as info:  # the sweep's filters need their table too
        world_from_dict(doc, name="bad", source="bad.toml")
    assert info.value.key == "filters.hinf" and "srchinf" in str(info.value)


def test_the_gamma_sweep_counts_its_fallbacks() -> None:
    world = alignment_world(3.0, **{"sweep.gammas": [0.2, math.inf], "sweep.runs": 2,
                                    "filters.names": ["ukf", "uthinf"],
                                    "sweep.filters": ["uthinf"]})
    names = list(world.filters.names)
    outs = [run_once(world, r, np.random.SeedSequence(0, spawn_key=(r,)), names,
                     reference=False) for r in range(3)]
    assert [len(o.sweep) for o in outs] == [2, 2, 0]
    s = summarize(world, outs, names, 3, 0)
    small, inf = s["gamma_sweep"]["rows"]
    assert small["gamma"] == 0.2 and inf["gamma"] is None and inf["gamma_text"] == "∞"
    # λmax(P_KF) starts near sin²(15°) = 0.067 (30° azimuth σ) > γ² = 0.04: the check fails
    cells = [c for o in outs[:2] for c in o.sweep if c.gamma == 0.2]
    assert small["fallbacks"] == sum(c.fallbacks for c in cells) > 0
    assert small["runs_with_fallbacks"] == 2 and small["diverged"] == 0
    assert small["updates"] == 2 * world.n_epochs
    assert inf["fallbacks"] == 0 and inf["runs"] == 2
    assert inf["vs_twin"]["twin"] == "ukf" and inf["vs_twin"]["runs"] == 2
    assert abs(inf["vs_twin"]["mean"]) < 1e-9 * s["ranking"]["level"]["rows"]["ukf"]["mse"]
    # the campaign's own H∞ filter at the world's γ = 5 counts its fallbacks too (none)
    assert s["filters"]["uthinf"]["hinf_fallbacks"] == 0
    assert s["filters"]["uthinf"]["hinf_updates"] == 3 * world.n_epochs
