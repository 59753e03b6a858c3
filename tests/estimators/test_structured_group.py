"""The pieces of the structured group prediction (:func:`estimators.structured._predict_group`)
against what they replace: the factor's columns of a few point pairs against the full
factor's, the rotated map block against ``lower_factor``, the in-place batched rank update
against the per-member sweep (a factor of condition 1e12 included), and the whole step on
a map-less state and on a batch of ill-conditioned beliefs against the dense step."""

from __future__ import annotations

import numpy as np
import pytest

from estimators import structured
from estimators.linalg import chol_update_sweep, tria
from estimators.models import SqrtGaussian
from estimators.rules import CentralDifference, Cubature, Unscented
from estimators.sigma import sigma_predict
from estimators.slam_group import SlamGroup
from estimators.structured import FALLBACKS, dense_steps

RULES = [Cubature(), Unscented(), Unscented(1.0, 0.0, "3-n"), CentralDifference()]


def _rel(a, b) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _lower(S, cond: float | None, rng, lead=()) -> np.ndarray:
    n = S if isinstance(S, int) else S.shape[-1]
    if cond is None:
        L = np.tril(rng.normal(size=lead + (n, n))) * 0.3
        i = np.arange(n)
        L[..., i, i] = np.abs(L[..., i, i]) + 0.2
        return L
    U, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return np.broadcast_to(tria(U * np.logspace(0.0, -0.5 * np.log10(cond), n)),
                           lead + (n, n)).copy()


@pytest.mark.parametrize("rule", RULES, ids=lambda r: f"{r.name}-{getattr(r, 'settings', '')}")
def test_pair_columns_are_the_full_factors_columns(rule):
    rng = np.random.default_rng(5)
    N, d = 9, 7
    centre = not isinstance(rule, Cubature)
    m = 2 * N + int(centre)
    D = rng.normal(size=(2, m, d))
    D0 = D[:, 0] if centre else rng.normal(size=(2, d))
    off = int(centre)
    inactive = 4  # both of its points at the reduced cloud's row 0
    D[:, off + inactive], D[:, off + N + inactive] = D0, D0
    sel = np.array([0, 2, 7])
    red = np.concatenate([D0[:, None], D[:, off + sel], D[:, off + N + sel]], axis=1)
    k = len(sel)
    tail = np.array([0])
    G, rest, c0, sign = structured._pair_columns(rule, red, N, np.r_[1:1 + k, tail],
                                                 np.r_[1 + k:1 + 2 * k, tail])
    fac = rule.factor(D)
    Gf, rf = structured._pairs(rule, fac.C, N)
    cols = np.r_[sel, inactive]
    assert np.array_equal(G, Gf[..., cols]) and np.array_equal(rest, rf[..., cols])
    assert not np.any(G[..., -1])
    if fac.c0 is None:
        assert c0 is None
    else:
        assert np.array_equal(c0, fac.c0) and sign == fac.sign


@pytest.mark.parametrize("side", ["right", "left"])
@pytest.mark.parametrize("lead", [(), (3,)])
def test_tail_block_is_the_lower_factor_of_the_rotated_map(side, lead):
    rng = np.random.default_rng(8)
    h, n = 3, 3 + 2 * 6
    S = _lower(n, None, rng, lead)
    a = rng.normal(size=lead) + 1j * rng.normal(size=lead)
    T = np.zeros(S.shape)  # the construction the block replaces
    lm = (S[..., h::2, h:] + 1j * S[..., h + 1::2, h:]) * np.asarray(a)[..., None, None]
    T[..., h::2, h:], T[..., h + 1::2, h:] = lm.real, lm.imag
    T = SlamGroup(6, side).lower_factor(T)
    before = S.copy()
    M = structured._tail_block(S, np.asarray(a), h)
    assert np.array_equal(S, before)
    assert M.flags.c_contiguous and M.shape == lead + (n - h, n - h)
    assert _rel(M, T[..., h:, h:]) < 1e-14
    assert not np.any(np.triu(M, 1)) and np.all(np.diagonal(M, axis1=-2, axis2=-1) >= 0.0)


@pytest.mark.parametrize("cond", [None, 1e12])
def test_batched_rank_update_is_the_per_member_sweep(cond):
    rng = np.random.default_rng(9)
    C = _lower(40, cond, rng, (4,))
    V = rng.normal(size=(4, 40, 6)) * 0.1
    C0, V0 = C.copy(), V.copy()
    out = structured.rank_update(C, V)
    assert np.array_equal(C, C0) and np.array_equal(V, V0)  # the caller's arrays kept
    for j in range(4):
        ref = chol_update_sweep(C[j], V[j], 1.0)
        assert _rel(out[j], ref) < 1e-12
        target = C[j] @ C[j].T + V[j] @ V[j].T
        assert _rel(out[j] @ out[j].T, target) < 1e-12
    assert np.all(np.diagonal(out, axis1=-2, axis2=-1) > 0.0)


def _car(side: str):
    from slam.kinds.planar.models import motion_model
    from slam.kinds.planar.variants import invariant_motion

    return invariant_motion(motion_model(0.025, 4.0, np.diag([0.09, 0.003]), 8), side)


@pytest.mark.parametrize("rule", RULES, ids=lambda r: f"{r.name}-{getattr(r, 'settings', '')}")
@pytest.mark.parametrize("side", ["right", "left"])
@pytest.mark.parametrize("n_lm,batch,cond", [(0, None, None), (0, 3, None), (10, 3, 1e12)])
def test_group_predict_equals_dense(rule, side, n_lm, batch, cond):
    """A map-less state (only the moved rows) and a batch of factors of condition 1e12."""
    rng = np.random.default_rng(31 + n_lm)
    n = 3 + 2 * n_lm
    lead = () if batch is None else (batch,)
    S = _lower(n, cond, rng, lead)
    mean = rng.normal(size=lead + (n,)) * 5.0
    mean[..., 2] = 0.4
    b = SqrtGaussian(mean, S, SlamGroup(n_lm, side))
    u = np.broadcast_to([3.0, 0.1], lead + (8, 2))
    FALLBACKS.clear()
    with dense_steps():
        try:
            ref = sigma_predict(rule, "sqrt", b, _car(side), u)
        except np.linalg.LinAlgError:  # a negative centre weight's downdate: both fail
            ref = None
    if ref is None:
        assert structured.predict(rule, b, _car(side), u) is None and FALLBACKS
        return
    out = structured.predict(rule, b, _car(side), u)
    assert out is not None and not FALLBACKS
    assert _rel(out.mean, ref.mean) < 1e-9
    assert _rel(out.sqrt, ref.sqrt) < 1e-9
    assert _rel(out.cov, ref.cov) < 1e-9
    d = np.diagonal(out.sqrt, axis1=-2, axis2=-1)
    assert not np.any(np.triu(out.sqrt, 1)) and np.all(d > 0.0)


@pytest.mark.parametrize("rule", RULES, ids=lambda r: f"{r.name}-{getattr(r, 'settings', '')}")
@pytest.mark.parametrize("slots,cond", [([5], None), ([1, 5], 1e12), ([2], 1e12)])
@pytest.mark.parametrize("side", ["right", None])
def test_update_reading_up_to_the_last_row_or_not_equals_dense(rule, slots, cond, side):
    """The update's points after the last read column lumped on the mean (one column of
    the innovation factor), and none to lump when the last landmark is read (a = n)."""
    from estimators.models import Measurement, Noise
    from estimators.sigma import sigma_update
    from estimators.spaces import Wrapped
    from slam.kinds.planar.models import range_bearing

    rng = np.random.default_rng(41)
    n_lm, lead = 6, (3,)
    n = 3 + 2 * n_lm
    S = _lower(n, cond, rng, lead)
    mean = rng.normal(size=lead + (n,)) * 5.0
    space = SlamGroup(n_lm, side) if side else Wrapped(n, (2,))
    b = SqrtGaussian(mean, S, space)
    s = np.asarray(slots)
    reads = (0, 1, 2, *[r for i in slots for r in (3 + 2 * i, 4 + 2 * i)])
    model = Measurement(lambda X: range_bearing(X, s), Noise.from_sigmas(np.tile([0.1, 0.05],
                                                                                  len(s))),
                        Wrapped(2 * len(s), tuple(range(1, 2 * len(s), 2))), reads=reads)
    z = model.h(mean[..., None, :])[..., 0, :] + 0.03
    with dense_steps():
        try:
            ref, rinn = sigma_update(rule, "sqrt", b, model, z)
        except np.linalg.LinAlgError:  # Julier's set: the dense step's own downdate fails
            return
    FALLBACKS.clear()
    out, inn = sigma_update(rule, "sqrt", b, model, z)
    applies = not (isinstance(rule, Unscented) and rule.weights_c(n)[0] < 0.0)
    assert (structured.update(rule, b, model, z) is not None) == applies and not FALLBACKS
    assert _rel(out.mean, ref.mean) < 1e-9 and _rel(out.sqrt, ref.sqrt) < 1e-9
    assert _rel(np.asarray(inn.nis), np.asarray(rinn.nis)) < 1e-9
    assert _rel(inn.sqrt_cov, rinn.sqrt_cov) < 1e-9
