"""The library boundary: a noise that is not finite, symmetric and positive semi-definite
never reaches a filter (every constructor raises :class:`estimators.NoiseError`), for
every filter; an H∞ bound whose 1/γ² is not finite is refused by ``make_filter``; a bad
noise built inside a run ends that run as a counted divergence."""

from __future__ import annotations

import numpy as np
import pytest

from estimators import (
    FILTER_NAMES,
    ROBUST_FILTER_NAMES,
    Euclidean,
    Measurement,
    Noise,
    NoiseError,
    Transition,
    make_filter,
)
from estimators.hinf import MIN_GAMMA
from estimators.loop import run_epochs

ALL = FILTER_NAMES + ROBUST_FILTER_NAMES
SPACE = Euclidean(2)

BAD_NOISES = {
    "nan covariance": lambda: Noise.from_cov([[np.nan]]),
    "nan sigma": lambda: Noise.from_sigmas([np.nan]),
    "infinite covariance": lambda: Noise.from_cov([[np.inf]]),
    "infinite sigma": lambda: Noise.from_sigmas([np.inf]),
    "sigma squaring to infinity": lambda: Noise.from_sigmas([1e200]),
    "sigma squaring to zero": lambda: Noise.from_sigmas([1e-300]),
    "subnormal variance": lambda: Noise.from_sigmas([1e-160]),
    "negative sigma": lambda: Noise.from_sigmas([-1.0]),
    "asymmetric covariance": lambda: Noise.from_cov([[1.0, 0.5], [0.0, 1.0]]),
    "negative eigenvalue": lambda: Noise.from_cov([[1.0, 2.0], [2.0, 1.0]]),
    "negative variance": lambda: Noise.from_cov([[-1.0]]),
    "factor with nan": lambda: Noise.from_sqrt([[np.nan]]),
    "factor squaring to infinity": lambda: Noise.from_sqrt([[1e200]]),
    "raw nan": lambda: Noise(np.array([[np.nan]]), np.array([[1.0]])),
    "raw inconsistent factor": lambda: Noise(np.eye(2), 2.0 * np.eye(2)),
    "raw wrong rows": lambda: Noise(np.eye(2), np.eye(3)),
}


@pytest.mark.parametrize("case", sorted(BAD_NOISES))
def test_every_noise_constructor_refuses_bad_input(case):
    with pytest.raises(NoiseError):
        BAD_NOISES[case]()


def test_noise_error_is_a_value_error_and_counts_as_a_divergence():
    assert issubclass(NoiseError, ValueError) and issubclass(NoiseError, ArithmeticError)


def _belief(name: str):
    return make_filter(name).init(np.zeros(2), SPACE, cov=np.eye(2))


def _transition(noise: Noise) -> Transition:
    return Transition(lambda X, u: X + 0.1, noise)


def _measurement(noise: Noise) -> Measurement:
    return Measurement(lambda X: X[:, :1] * 2.0, noise)


@pytest.mark.parametrize("case", ["nan covariance", "infinite covariance", "nan sigma",
                                  "sigma squaring to zero"])
@pytest.mark.parametrize("name", ALL)
def test_no_filter_can_be_given_a_non_finite_noise(name, case):
    """The noise a model would carry cannot be built, so neither ``predict`` nor
    ``update`` can return a NaN belief or raise a raw ``LinAlgError`` from it; the same
    filter with a valid noise of the same shape runs (the check is the noise's)."""
    with pytest.raises(NoiseError):
        _measurement(BAD_NOISES[case]())
    with pytest.raises(NoiseError):
        _transition(BAD_NOISES[case]())
    filt = make_filter(name)
    b = filt.predict(_belief(name), _transition(Noise.from_sigmas([0.1, 0.1])), None)
    post, inn = filt.update(b, _measurement(Noise.from_sigmas([0.2])), np.array([0.3]))
    assert np.isfinite(post.mean).all() and np.isfinite(post.cov).all()
    assert np.isfinite(inn.nis)


@pytest.mark.parametrize("name", ALL)
def test_a_semidefinite_noise_is_valid(name):
    """A noise exactly zero in some direction (positive semi-definite) is accepted and
    gives a finite belief."""
    noise = Noise.from_cov(np.diag([0.0, 0.01]))
    assert noise.sqrt.shape == (2, 2)
    filt = make_filter(name)
    b = filt.predict(_belief(name), _transition(noise), None)
    assert np.isfinite(b.mean).all() and np.isfinite(b.cov).all()


def test_measurement_noise_must_match_its_space():
    with pytest.raises(NoiseError, match="2-dimensional, its space 1-dimensional"):
        Measurement(lambda X: X, Noise.from_sigmas([1.0, 1.0]), Euclidean(1))


def test_models_need_callables():
    with pytest.raises(TypeError):
        Transition("not callable", Noise.from_sigmas([1.0]))  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        Measurement(lambda X: X, np.eye(1))  # type: ignore[arg-type]


@pytest.mark.parametrize("gamma", [1e-300, 1e-160, 0.0, -1.0, float("nan")])
@pytest.mark.parametrize("name", ROBUST_FILTER_NAMES)
def test_a_gamma_whose_inverse_square_is_not_finite_is_refused(name, gamma):
    with pytest.raises(ValueError, match="gamma"):
        make_filter(name, gamma=gamma)


@pytest.mark.parametrize("name", ROBUST_FILTER_NAMES)
def test_the_smallest_gamma_allowed_updates_without_a_zero_division(name):
    """At γ = MIN_GAMMA the update either falls back (counted) or raises the named
    Riccati error; never ``ZeroDivisionError``."""
    filt = make_filter(name, gamma=MIN_GAMMA, on_failure="kalman")
    _, inn = filt.update(_belief(name), _measurement(Noise.from_sigmas([0.2])), np.array([0.3]))
    assert inn.hinf_fallback


@pytest.mark.parametrize("name", ["ekf", "srckf", "ukf"])
def test_a_filter_refuses_a_setting_it_does_not_take(name):
    with pytest.raises(ValueError, match="takes no setting 'gamma'"):
        make_filter(name, gamma=2.0)


def test_a_bad_noise_made_inside_a_run_is_a_counted_divergence():
    """A noise computed from the run's own numbers (here a NaN interval) ends the run
    with its reason instead of escaping the filter loop."""
    filt = make_filter("srckf")
    meas = _measurement(Noise.from_sigmas([0.2]))
    dts = [0.1, 0.1, np.nan, 0.1]

    def transition(e, b):
        return _transition(Noise.from_sigmas([dts[e], dts[e]])), None

    out = run_epochs(filt, _belief("srckf"), 4, transition=transition,
                     correct=lambda e, b: (lambda r: (r[0], [r[1]]))(
                         filt.update(b, meas, np.array([0.0]))),
                     record=lambda e, b: None)
    assert out.diverged and out.failure.startswith("NoiseError: noise sigma is not finite")
    assert out.epochs_done == 1
