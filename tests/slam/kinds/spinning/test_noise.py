"""The true-noise shapes (:mod:`slam.kinds.spinning.noise`)."""

from __future__ import annotations

import numpy as np
import pytest

from slam.kinds.spinning.noise import NoiseShape, unit_noise


@pytest.mark.parametrize("shape", [NoiseShape(), NoiseShape(distribution="student-t",
                                                            student_t_dof=5.0),
                                   NoiseShape(distribution="contaminated")])
def test_unit_noise_has_the_stated_spread(shape: NoiseShape) -> None:
    e = unit_noise(np.random.default_rng(0), (200_000,), shape)
    assert abs(e.mean()) < 0.02
    assert e.std() == pytest.approx(shape.std_ratio, rel=0.03)


def test_every_shape_draws_the_same_stream() -> None:
    rng = [np.random.default_rng(1) for _ in range(3)]
    for r, d in zip(rng, ("gaussian", "student-t", "contaminated")):
        unit_noise(r, (10, 3), NoiseShape(distribution=d))
    after = [r.random() for r in rng]
    assert after[0] == after[1] == after[2]


def test_student_t_has_heavier_tails_than_the_gaussian() -> None:
    g = unit_noise(np.random.default_rng(2), (100_000,), NoiseShape())
    t = unit_noise(np.random.default_rng(2), (100_000,), NoiseShape(distribution="student-t"))
    assert np.mean(np.abs(t) > 4.0) > 10 * np.mean(np.abs(g) > 4.0)
