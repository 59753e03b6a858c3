"""The GTSAM reference of the alignment: a noise-free log is recovered, and its marginals
pass a χ² NEES test on a small case (misalignment drawn from the prior, no wind)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from slam.kinds.alignment.run import run_reference
from slam.kinds.alignment.simulate import simulate_alignment
from slam.scoring import anees_band
from tests.slam.kinds.alignment.worlds import CALM, NO_ERRORS, alignment_world


def test_noise_free_log_is_recovered() -> None:
    world = alignment_world(3.0, **NO_ERRORS, **CALM)
    s = run_reference(world, simulate_alignment(world, np.random.default_rng(0)))
    assert not s.diverged, s.failure
    # from 10, 10, 30 deg: the level is found, the azimuth stays at the prior's mean
    err = s.err[np.isfinite(s.err[:, 0])]
    assert np.max(np.abs(err[:, :2])) < 1e-3 * math.pi / 180 / 60 * 1e3  # < 1′
    assert abs(math.degrees(err[-1, 2]) + 30.0) < 0.5


def test_marginals_pass_a_chi2_nees_test() -> None:
    sigma = np.radians([1.0, 1.0, 1.0])
    # the zero-velocity and position references are exact here (no wind), so their factors
    # get a small σ: what is left to estimate is set by noises the simulation draws
    base = alignment_world(3.0, **CALM, **{"filters.initial_sigma_deg": [1.0, 1.0, 1.0],
                                           "filters.velocity_sigma_mps": 1e-4,
                                           "reference.position_sigma_m": 1e-4})
    rng = np.random.default_rng(42)
    nees = []
    for run in range(16):
        mis = tuple(rng.standard_normal(3) * sigma)
        world = replace(base, filters=replace(base.filters, initial_misalignment_rad=mis))
        s = run_reference(world, simulate_alignment(world, np.random.default_rng(run)))
        assert s.note is None, s.note
        nees.append(s.nees[np.isfinite(s.nees)][-1])  # one per run: keys are correlated
    avg = np.mean(nees) / 3.0
    lo, hi = anees_band(len(nees), 3)
    assert lo <= avg <= hi, (avg, lo, hi)
