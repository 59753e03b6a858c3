"""Every filter raises a named error (:class:`estimators.NonFiniteError`) at the step that
receives a non-finite value - a measurement, a prior, a transition's or a measurement
model's output - in joint and (where it exists) partitioned mode; the filter loop counts
it as a divergence; and a dense filter starts from a singular prior covariance."""

from __future__ import annotations

import numpy as np
import pytest

from estimators import (
    FILTER_NAMES,
    ROBUST_FILTER_NAMES,
    BlockLayout,
    Euclidean,
    Measurement,
    Noise,
    NonFiniteError,
    Transition,
    make_filter,
)
from estimators.loop import run_epochs

ALL = FILTER_NAMES + ROBUST_FILTER_NAMES
BAD = [np.nan, np.inf, -np.inf]
SPACE = Euclidean(2)
NOISE = Noise.from_sigmas([0.1, 0.1])


def _transition(poison: float | None = None) -> Transition:
    def f(X, u):
        Y = X + 0.1
        if poison is not None:
            Y = Y.copy()
            Y[:, 1] = poison
        return Y

    return Transition(f, NOISE, jacobian=None)


def _measurement(poison: float | None = None) -> Measurement:
    def h(X):
        Z = X[:, :1] * 2.0
        return Z if poison is None else np.full_like(Z, poison)

    return Measurement(h, Noise.from_sigmas([0.2]))


def _belief(name: str):
    return make_filter(name).init(np.zeros(2), SPACE, cov=np.eye(2))


@pytest.mark.parametrize("bad", BAD)
@pytest.mark.parametrize("name", ALL)
def test_non_finite_measurement_is_named(name, bad):
    with pytest.raises(NonFiniteError, match="non-finite measurement"):
        make_filter(name).update(_belief(name), _measurement(), np.array([bad]))


@pytest.mark.parametrize("name", ALL)
def test_non_finite_model_outputs_are_named(name):
    filt = make_filter(name)
    with pytest.raises(NonFiniteError, match="transition input"):
        filt.predict(_belief(name), _transition(), np.array([1.0, np.nan]))
    with pytest.raises(NonFiniteError, match="transition|model output"):
        filt.predict(_belief(name), _transition(np.inf), None)
    with pytest.raises(NonFiniteError, match="measurement model output|model output"):
        filt.update(_belief(name), _measurement(np.nan), np.array([0.5]))


@pytest.mark.parametrize("name", ALL)
def test_non_finite_prior_is_named(name):
    filt = make_filter(name)
    with pytest.raises(NonFiniteError, match="prior"):
        filt.init(np.array([0.0, np.nan]), SPACE, cov=np.eye(2))
    with pytest.raises(NonFiniteError, match="prior"):
        filt.init(np.zeros(2), SPACE, sqrt=np.array([[1.0, 0.0], [np.nan, 1.0]]))
    with pytest.raises(NonFiniteError, match="prior"):
        filt.init(np.zeros(2), SPACE, cov=np.diag([1.0, np.inf]))


@pytest.mark.parametrize("name", [n for n in ALL if make_filter(n).supports_partitioned])
def test_partitioned_steps_name_non_finite_values(name):
    layout = BlockLayout.of(lambda n: Euclidean(2 + 2 * n))
    steps = make_filter(name).partitioned(layout)
    b = make_filter(name).init(np.zeros(4), Euclidean(4), cov=np.eye(4))
    with pytest.raises(NonFiniteError):
        steps.predict(b, _transition(np.nan), None)
    with pytest.raises(NonFiniteError, match="measurement"):
        steps.update(b, np.array([0]), Measurement(lambda X: X[:, 2:3] - X[:, :1],
                                                    Noise.from_sigmas([0.2])), np.array([np.inf]))


@pytest.mark.parametrize("name", ALL)
def test_the_loop_counts_it_as_a_divergence_at_that_epoch(name):
    filt = make_filter(name)
    zs = [0.1, 0.2, np.nan, 0.3]

    def correct(e, b):
        b, inn = filt.update(b, _measurement(), np.array([zs[e]]))
        return b, [inn]

    out = run_epochs(filt, _belief(name), 4, transition=lambda e, b: (_transition(), None),
                     correct=correct, record=lambda e, b: None)
    assert out.diverged and out.epochs_done == 1
    assert out.failure.startswith("NonFiniteError: non-finite measurement")


@pytest.mark.parametrize("name", ALL)
def test_a_singular_prior_runs(name):
    """A zero (or rank-deficient) prior covariance, e.g. a start known exactly: dense
    filters factor it as the square-root ones carry it."""
    filt = make_filter(name)
    b = filt.init(np.zeros(2), SPACE, sqrt=np.diag([0.0, 0.5]))
    b = filt.predict(b, _transition(), None)
    b, inn = filt.update(b, _measurement(), np.array([0.3]))
    assert np.all(np.isfinite(b.mean)) and np.isfinite(inn.nis)
