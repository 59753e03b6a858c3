"""A batch of beliefs (leading axes) through every filter's predict and update gives, for
each member, what the per-run call gives (to 1e-9 relative; the worst case is printed by
``pytest -s``): the same filter code serves one run and a Monte Carlo batch."""

from __future__ import annotations

import numpy as np
import pytest

from estimators import (
    FILTER_NAMES,
    ROBUST_FILTER_NAMES,
    Measurement,
    Noise,
    Transition,
    Wrapped,
    make_filter,
)
from estimators.models import SqrtGaussian

ALL = FILTER_NAMES + ROBUST_FILTER_NAMES
SPACE = Wrapped(4, (2,))  # [x, y, heading, v]
SETTINGS = {"ukf": {"alpha": 1.0, "beta": 0.0, "kappa": "3-n"},
            "srukf": {"alpha": 0.7, "beta": 2.0, "kappa": 0.0},   # negative centre weight
            "uthinf": {"alpha": 1.0, "beta": 0.0, "kappa": "3-n", "gamma": 3.0,
                       "on_failure": "kalman"},
            "srchinf": {"gamma": 3.0, "on_failure": "kalman"},
            "cdkf": {"h": 1.5}}
R = 5


def _f(X, u, W):
    """A unicycle with noise on speed and turn rate, broadcast over leading axes."""
    v = X[..., 3] + W[..., 0]
    th = X[..., 2]
    Y = np.array(X, copy=True)
    Y[..., 0] += u[..., 0:1] * v * np.cos(th)
    Y[..., 1] += u[..., 0:1] * v * np.sin(th)
    Y[..., 2] = np.mod(th + u[..., 1:2] + W[..., 1] + np.pi, 2 * np.pi) - np.pi
    return Y


def _h(X):
    """Range and bearing of the origin-relative landmark (10, 5)."""
    dx, dy = 10.0 - X[..., 0], 5.0 - X[..., 1]
    b = np.mod(np.arctan2(dy, dx) - X[..., 2] + np.pi, 2 * np.pi) - np.pi
    return np.stack([np.hypot(dx, dy), b], axis=-1)


def _f_jacobian(x, u):
    """(F, G) of :func:`_f` at ``x`` (..., 4), batched."""
    v, th, dt = x[..., 3], x[..., 2], u[..., 0]
    F = np.broadcast_to(np.eye(4), x.shape[:-1] + (4, 4)).copy()
    F[..., 0, 2], F[..., 0, 3] = -dt * v * np.sin(th), dt * np.cos(th)
    F[..., 1, 2], F[..., 1, 3] = dt * v * np.cos(th), dt * np.sin(th)
    G = np.zeros(x.shape[:-1] + (4, 2))
    G[..., 0, 0], G[..., 1, 0], G[..., 2, 1] = dt * np.cos(th), dt * np.sin(th), 1.0
    return F, G


TRANSITION = Transition(_f, Noise.from_sigmas([0.2, 0.05]), additive=False)
TRANSITION_J = Transition(_f, Noise.from_sigmas([0.2, 0.05]), additive=False,
                          jacobian=_f_jacobian)
MEASUREMENT = Measurement(_h, Noise.from_sigmas([0.1, 0.02]), Wrapped(2, (1,)))


def _h_jacobian(x):
    """H of :func:`_h` at ``x`` (..., 4), batched."""
    dx, dy = 10.0 - x[..., 0], 5.0 - x[..., 1]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    H = np.zeros(x.shape[:-1] + (2, 4))
    H[..., 0, 0], H[..., 0, 1] = -dx / r, -dy / r
    H[..., 1, 0], H[..., 1, 1], H[..., 1, 2] = dy / q, -dx / q, -1.0
    return H


MEASUREMENT_J = Measurement(_h, MEASUREMENT.noise, MEASUREMENT.space, jacobian=_h_jacobian)


def _beliefs(filt, rng):
    means = np.column_stack([rng.normal(0, 1, R), rng.normal(0, 1, R),
                             rng.uniform(-3.1, 3.1, R), rng.uniform(0.5, 2.0, R)])
    A = rng.normal(0, 0.3, (R, 4, 4))
    covs = A @ np.swapaxes(A, -1, -2) + 0.05 * np.eye(4)
    singles = [filt.init(m, SPACE, cov=c) for m, c in zip(means, covs)]
    if isinstance(singles[0], SqrtGaussian):
        batch = SqrtGaussian(means, np.stack([b.sqrt for b in singles]), SPACE)
    else:
        batch = type(singles[0])(means, np.stack([b.cov for b in singles]), SPACE)
    return singles, batch


def _close(a, b, what):
    scale = max(1.0, float(np.max(np.abs(b))))
    err = float(np.max(np.abs(np.asarray(a) - np.asarray(b)))) / scale
    assert err <= 1e-9, f"{what}: {err:.2e}"
    return err


BATCHED = [n for n in ALL if make_filter(n).batched]


def test_the_filters_without_a_batched_update_refuse_a_batch():
    for name in sorted(set(ALL) - set(BATCHED)):
        filt = make_filter(name)
        _, batch = _beliefs(filt, np.random.default_rng(0))
        with pytest.raises(ValueError, match="no batched"):
            filt.update(batch, MEASUREMENT, np.zeros((R, 2)))


@pytest.mark.parametrize("name", BATCHED)
def test_a_batch_equals_the_runs_one_by_one(name):
    filt = make_filter(name, **SETTINGS.get(name, {}))
    rng = np.random.default_rng(1)
    singles, batch = _beliefs(filt, rng)
    u = np.tile([0.1, 0.05], (R, 1))
    z = np.column_stack([rng.uniform(8, 12, R), rng.uniform(-3, 3, R)])
    worst = 0.0
    for _ in range(3):
        batch = filt.predict(batch, TRANSITION, u)
        singles = [filt.predict(b, TRANSITION, u[r]) for r, b in enumerate(singles)]
        batch, binn = filt.update(batch, MEASUREMENT, z)
        out = [filt.update(b, MEASUREMENT, z[r]) for r, b in enumerate(singles)]
        singles = [o[0] for o in out]
        worst = max(worst, _close(batch.mean, np.stack([b.mean for b in singles]), "mean"),
                    _close(batch.cov, np.stack([b.cov for b in singles]), "cov"),
                    _close(binn.nis, np.array([o[1].nis for o in out]), "nis"),
                    _close(binn.nu, np.stack([o[1].nu for o in out]), "innovation"))
        if name in ROBUST_FILTER_NAMES:
            assert np.array_equal(binn.hinf_fallback, [o[1].hinf_fallback for o in out])
    print(f"{name}: worst relative difference {worst:.1e}")


def test_the_ekf_linearises_a_batch_numerically_and_analytically():
    """Without a model Jacobian the EKF differentiates a batch in one call; with one it
    uses the model's (batched) Jacobian: both equal the per-run EKF."""
    filt = make_filter("ekf")
    rng = np.random.default_rng(3)
    singles, batch = _beliefs(filt, rng)

    analytic = MEASUREMENT_J
    z = np.column_stack([rng.uniform(8, 12, R), rng.uniform(-3, 3, R)])
    for model in (MEASUREMENT, analytic):
        post, _ = filt.update(batch, model, z)
        ref = [filt.update(b, model, z[r])[0] for r, b in enumerate(singles)]
        _close(post.mean, np.stack([b.mean for b in ref]), "mean")
        _close(post.cov, np.stack([b.cov for b in ref]), "cov")


def _loop_case(filt, rng, bad_run: int | None, diverge_run: int | None):
    """Hooks for a 6-epoch loop: run ``bad_run`` gets a NaN measurement at epoch 3, run
    ``diverge_run`` trips the check at epoch 4; the batch and per-run forms of each."""
    from estimators.loop import Divergence

    zs = np.column_stack([rng.uniform(8, 12, (6, R)), rng.uniform(-3, 3, (6, R))]
                         ).reshape(6, 2, R).transpose(0, 2, 1)
    if bad_run is not None:
        zs[3, bad_run, 0] = np.nan
    u = np.array([0.1, 0.05])

    def transition(e, b, live=None):
        # analytic Jacobians (here and in the update): a finite-difference one turns 1-ulp
        # differences between the batched and the per-run arithmetic into ~1e-10 per step
        # (eps = 1e-6); which elements differ by an ulp depends on the CPU's vector width
        # (numpy's AVX-512 loops: 2.1e-9 after six epochs of the EKF on one machine)
        return TRANSITION_J, (u if live is None else np.tile(u, (len(live), 1)))

    def correct(e, b, live=None):
        z = zs[e, live] if live is not None else zs[e, correct.run]
        post, inn = filt.update(b, MEASUREMENT_J, z)
        return post, [inn]

    def check(e, b, live=None):
        runs = [check.run] if live is None else list(live)
        if diverge_run in runs and e == 4:
            raise Divergence(f"run {diverge_run} left its bounds at epoch {e}")

    return transition, correct, check


@pytest.mark.parametrize("name", ["srckf", "ekf", "srukf"])
def test_a_failing_run_ends_alone_with_its_per_run_reason(name):
    from estimators.batch import run_batch
    from estimators.loop import run_epochs

    filt = make_filter(name, **SETTINGS.get(name, {}))
    rng = np.random.default_rng(5)
    singles, batch = _beliefs(filt, rng)
    transition, correct, check = _loop_case(filt, rng, bad_run=1, diverge_run=3)
    seen = {}

    def record(e, b, live):
        for j, r in enumerate(live):
            seen[(e, int(r))] = np.array(b.mean[j])

    results = run_batch(filt, batch, 6, transition=transition, correct=correct, record=record,
                        check=check)
    for r, b0 in enumerate(singles):
        correct.run = check.run = r
        mine = {}

        def keep(e, b, r=r, mine=mine):
            mine[(e, r)] = np.array(b.mean)

        ref = run_epochs(filt, b0, 6, transition=lambda e, b: transition(e, b),
                         correct=lambda e, b: correct(e, b), check=lambda e, b: check(e, b),
                         record=keep)
        got = results[r]
        assert got.failure == ref.failure and got.epochs_done == ref.epochs_done
        _close(got.belief.mean, ref.belief.mean, "last belief")
        np.testing.assert_array_equal(got.nis_epoch, ref.nis_epoch)
        _close(got.nis, ref.nis, "nis")
        for key, value in mine.items():
            _close(seen[key], value, f"record {key}")
    assert results[1].failure.startswith("NonFiniteError: non-finite measurement")
    assert results[3].failure.startswith("Divergence: run 3")
    assert [r.failure for i, r in enumerate(results) if i not in (1, 3)] == [None] * (R - 2)


@pytest.mark.parametrize("name", ["ekf", "srckf", "ukf", "srcdkf"])
def test_a_batch_of_noises_one_per_run(name):
    """A transition built along each run's own mean (the drone's) carries one noise per
    run: ``Noise`` with leading axes, equal to each run's own call."""
    filt = make_filter(name, **SETTINGS.get(name, {}))
    rng = np.random.default_rng(7)
    singles, batch = _beliefs(filt, rng)
    sig = rng.uniform(0.01, 0.2, (R, 4))
    noise = Noise.from_sigmas(sig)
    assert noise.cov.shape == (R, 4, 4) and noise.dim == 4
    model = Transition(lambda X, u: X + u[..., None, :], noise)
    u = rng.normal(0, 0.1, (R, 4))
    out = filt.predict(batch, model, u)
    for r, b in enumerate(singles):
        one = filt.predict(b, Transition(lambda X, u: X + u, Noise.from_sigmas(sig[r])), u[r])
        _close(out.mean[r], one.mean, "mean")
        _close(out.cov[r], one.cov, "cov")


def test_wrapped_space_wraps_evenly_and_unevenly_spaced_angles_alike():
    from estimators.spaces import wrap_angle
    rng = np.random.default_rng(5)
    x = rng.uniform(-10.0, 10.0, size=(3, 4, 7))
    for angles in [(1, 3, 5), (0, 2, 3), (6,), ()]:
        space = Wrapped(7, angles)
        want = x.copy()
        for i in angles:
            want[..., i] = wrap_angle(x[..., i])
        np.testing.assert_array_equal(space.retract(x, np.zeros(7)), want)
        np.testing.assert_array_equal(space.local(np.zeros(7), x), want)
