"""nav.ins.preintegrate_stack: several epochs preintegrated at once equal each epoch's own
:func:`nav.ins.preintegrate` (padding with zero-length samples changes nothing), and
:func:`nav.ins.ins_transition` given the increments equals computing them itself."""

from __future__ import annotations

import numpy as np
import pytest

import nav.ins as ins
from nav.gravity import gravity_vector
from nav.imu_noise import BiasProcess, ImuPsd
from nav.ins import pad_epochs, preintegrate_stack
from nav.quaternion import qexp

FIELDS = ("dq", "dv", "dp", "J", "R_samples")


def _epoch(rng: np.random.Generator, n: int, fast: bool) -> tuple:
    rate = 3.0 if fast else 0.2  # rad/s: the series and the closed-form Γ coefficients
    return (rng.normal(0.0, rate, (n, 3)), rng.normal([0.0, 0.0, 9.8], 2.0, (n, 3)),
            rng.uniform(0.002, 0.02, n))


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_each_epoch_of_the_stack_is_its_own_preintegration(seed):
    rng = np.random.default_rng(seed)
    counts = rng.integers(1, 130, 7)
    pieces = [_epoch(rng, int(n), bool(k % 2)) for k, n in enumerate(counts)]
    b = np.column_stack([rng.normal(0, 1e-2, (7, 3)), rng.normal(0, 0.2, (7, 3))])
    g, f, h, got_counts = pad_epochs(pieces)
    np.testing.assert_array_equal(got_counts, counts)
    assert h.shape == (7, counts.max()) and np.all(h[0, counts[0]:] == 0.0)
    stack = preintegrate_stack(g, f, h, b, got_counts)
    worst = 0.0
    for p, (gy, ac, dt), be in zip(stack, pieces, b):
        one = ins.preintegrate(gy, ac, dt, be)
        for name in FIELDS:
            assert getattr(p, name).shape == getattr(one, name).shape, name
            worst = max(worst, _rel(getattr(p, name), getattr(one, name)))
        assert p.tau == pytest.approx(one.tau, rel=1e-14)
        np.testing.assert_array_equal(p.b, be)
    assert worst < 1e-12


def _model() -> ins.InsModel:
    psd = ImuPsd(1e-3, 2e-2, BiasProcess(walk_psd=1e-9), BiasProcess(walk_psd=1e-6))
    return ins.InsModel(psd, gravity_vector(0.8, 100.0))


def test_given_increments_at_the_means_biases_are_the_transition_itself():
    rng = np.random.default_rng(4)
    gy, ac, dt = _epoch(rng, 90, False)
    x = np.concatenate([[1.0, 2.0, 3.0], [4.0, -1.0, 0.5], qexp([0.1, -0.2, 0.3]),
                        [1e-3, -2e-3, 5e-4], [0.05, -0.02, 0.1]])
    model = _model()
    pre = preintegrate_stack(*pad_epochs([(gy, ac, dt)])[:3], x[None, 10:16])[0]
    own, given = ins.ins_transition(x, gy, ac, dt, model), ins.ins_transition(
        x, gy, ac, dt, model, pre=pre)
    X = x + np.concatenate([rng.normal(0, 0.1, (9, 6)), np.zeros((9, 4)),
                            rng.normal(0, 1e-3, (9, 6))], axis=1)
    X[:, 6:10] = x[6:10]
    np.testing.assert_array_equal(given.f(X, None), own.f(X, None))
    np.testing.assert_array_equal(given.jacobian(x, None), own.jacobian(x, None))
    np.testing.assert_array_equal(given.noise.cov, own.noise.cov)


def test_increments_for_a_mechanised_prediction_are_refused():
    rng = np.random.default_rng(5)
    gy, ac, dt = _epoch(rng, 20, False)
    x = np.concatenate([np.zeros(6), [1.0, 0.0, 0.0, 0.0], np.zeros(6)])
    pre = ins.preintegrate(gy, ac, dt, np.zeros(6))
    with pytest.raises(ValueError, match="mechanised prediction"):
        ins.ins_transition(x, gy, ac, dt, _model(), preintegrated=False, pre=pre)
