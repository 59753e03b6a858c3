"""The alignment filters: a noise-free log (no IMU errors, no wind, no misalignment) is
tracked by every filter to round-off; ``uthinf`` with γ = ∞ is the UKF on this model to
1e-9; with the large misalignment every filter levels from 600′ to within 10′ in 4 s."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from slam.kinds.alignment.run import run_filter
from slam.kinds.alignment.simulate import simulate_alignment
from tests.slam.kinds.alignment.worlds import CALM, NO_ERRORS, alignment_world

NAMES = ("ukf", "uthinf", "srckf", "srchinf", "ekf")
ARCMIN = math.pi / 180 / 60


@pytest.fixture(scope="module")
def noisy():
    world = alignment_world(4.0)
    return world, simulate_alignment(world, np.random.default_rng(11))


def test_noise_free_log_is_tracked_to_round_off() -> None:
    world = alignment_world(2.0, **NO_ERRORS, **CALM, **{
        "filters.initial_misalignment_deg": [0.0, 0.0, 0.0],
        "filters.initial_sigma_deg": [0.01, 0.01, 0.01]})
    log = simulate_alignment(world, np.random.default_rng(0))
    for name in NAMES:
        s = run_filter(world, log, name)
        assert not s.diverged, (name, s.failure)
        # the prior's own mean offset (1 - E cos(|phi|/2) ~ 1e-9) bounds the error
        assert np.max(np.abs(s.err)) < 1e-8, name


def test_uthinf_with_infinite_gamma_is_the_ukf(noisy) -> None:
    world, log = noisy
    inf = replace(world, filters=replace(world.filters, hinf={**world.filters.hinf,
                                                              "gamma": math.inf}))
    a, b = run_filter(inf, log, "uthinf"), run_filter(inf, log, "ukf")
    assert not a.diverged and not b.diverged
    assert np.max(np.abs(a.err - b.err)) < 1e-9
    assert np.max(np.abs(a.sigma - b.sigma)) < 1e-9
    assert np.allclose(a.nees13, b.nees13, rtol=1e-9)
    # and gamma = 5 is not (the bound inflates the covariance)
    c = run_filter(world, log, "uthinf")
    assert np.max(np.abs(c.sigma - b.sigma)) > 1e-9


def test_every_filter_levels_from_a_large_misalignment(noisy) -> None:
    world, log = noisy
    for name in NAMES:
        s = run_filter(world, log, name)
        assert not s.diverged, (name, s.failure)
        # from 600′ to within 10′ after 4 s (their own 2σ there is about 8′)
        assert np.all(np.abs(s.err[-1, :2]) < 10 * ARCMIN), (name, s.err[-1] / ARCMIN)
        assert np.all(np.abs(s.err[0, :2]) > 500 * ARCMIN)
