r"""Structured square-root sigma-point steps for states with a static tail (a SLAM map).

Equal to the dense steps of :mod:`estimators.sigma` to round-off, at a fraction of their
arithmetic, when a model declares its structure (:attr:`Transition.moves`,
:attr:`Measurement.reads`) and the belief's space is coordinate-wise (``Euclidean``, or
``Wrapped`` with its angles among the moved rows).  Rules: cubature, unscented (its signed
centre term included) and central difference, whose factor maps a point pair
:math:`\pm c\,S_a e_j` of the augmented factor to the columns below (checked against the
dense step in ``tests/estimators/test_structured.py``).

Prediction (``f`` moves the first ``h`` rows, copies the rest; noise input ``w``).  With
:math:`S = [[A, 0], [B, C]]` (``A`` the moved rows' ``h × h`` block), the points along a
tail column have the moved part at the mean, so ``f`` is needed only at the ``2(h + q)``
points along the moved and noise columns and at the mean.  The rule's factor of all points
is, up to an orthogonal map of its columns,

.. math::

    \begin{bmatrix} G_v & E & 0 \\ B & 0 & C \end{bmatrix},\qquad
    G_v = \tfrac{1}{\sqrt2}(C^h_{+v} - C^h_{-v}),\quad
    E = [\tfrac{1}{\sqrt2}(C^h_{+w} - C^h_{-w}),\ \tfrac{1}{\sqrt2}(C^h_{+} + C^h_{-})]

(``C^h`` the rule's factor of the moved rows' deviations; central difference: the first
and second differences in place of the half-difference and half-sum).  With
:math:`E_c = \mathrm{tria}(E)` and the complete QR
:math:`[G_v^\top; E_c^\top] = Q [R; 0]`:

.. math::

    A' = R^\top,\quad B' = B Q_{11},\quad C' = \mathrm{tria}([C,\ B Q_{12}]),

a rank-``h`` update of ``C`` (:math:`O(h n^2)`, never a downdate; an unscented negative
centre weight is then one rank-one downdate of the whole factor, as in the dense step).
The tail's mean is unchanged.

Update (``h`` reads rows up to ``r``; a coordinate-wise space, a :class:`Product` whose
leading coordinate-wise parts hold rows ``0 .. r`` (an INS state's position and velocity
before its attitude), or one whose retraction keeps the first ``r + 1`` coordinates when ξ
is zero on its first ``r + 1`` rows, declared by a ``prefix_rows`` attribute:
:class:`~estimators.slam_group.SlamGroup`, so the invariant filters' updates too).  The
points along the columns after ``r`` leave the read rows at the mean, so their ``h`` is
:math:`h(\hat x)` exactly: ``h`` runs at ``2(r + 1) + 1`` points, the innovation factor
:math:`S_{zz}` is the dense step's, and
:math:`P_{xz} = S_{:, \le r} G_z^\top` (:math:`G_z` the half-differences of the rule's
factor :math:`C_z`, zero after ``r``).  With :math:`W = G_z^\top S_{zz}^{-\top}`
(``(r + 1) × nz``), :math:`K = S_{:, \le r} W S_{zz}^{-1}` and
:math:`S^+ S^{+\top} = S S^\top - K P_{zz} K^\top = S\,\mathrm{diag}(I - WW^\top,\ I)\,S^\top`,
so (Potter's square-root update, restricted to the columns up to ``r``)

.. math::

    \hat x^+ = \hat x \boxplus S_{:, \le r} W S_{zz}^{-1}\nu,\qquad
    S^+ = [\,S_{:, \le r}\,\mathrm{chol}(I - WW^\top),\ S_{:, > r}\,],

lower triangular with a positive diagonal: :math:`O(n r^2)`, a few batched calls.  A model
that selects its rows (``Measurement.selects``: :math:`h(x) = x_{\mathrm{reads}}`, a GNSS
fix of an INS state's position) needs no points: :math:`G_z = S_{\mathrm{reads}, \le r}`
and :math:`\hat z = \hat x_{\mathrm{reads}}` are what every rule gives for a linear ``h``
(the Kalman update, in Potter's form).
:math:`I - WW^\top = (I + G_z^\top M^{-1} G_z)^{-1}` (:math:`M = P_{zz} - G_zG_z^\top
\succeq R`) is positive definite; a Cholesky factorisation that fails in floating point
(or any other failure of a structured step) falls back to the dense step, counted in
:data:`FALLBACKS` by reason.

Prediction on a group error (:class:`~estimators.slam_group.SlamGroup`, either side, the
space declaring ``prefix_rows = moves = 3`` and a ``tail_gain``; a lower-triangular factor).
A point along a map column :math:`k \ge 3` has the pose of :math:`\hat x`, so its image
is :math:`\hat y = f(\hat x, u, 0)` with its landmarks moved, and its deviation from the
new mean is :math:`\ell \pm c\, a \odot S_k` exactly (:math:`\ell = \hat y \boxminus
\bar y`, :math:`a` one complex factor on every landmark pair, e.g. :math:`V^{-1}(φ_{\hat
y} - φ_{\bar y})` for the right error; the simpler :math:`S' = \mathrm{tria}([S,
G_w])`, which takes :math:`\ell = 0` and :math:`a = 1`, is not exact).  The map columns
:math:`a \odot S_k` are made lower triangular again by one Givens rotation per landmark
pair; the moved, noise and summed columns touch every row and are a rank-:math:`(h + r)`
update of them (:func:`_predict_group`; ``f`` at the same :math:`1 + 2(h + q)` points).

Not covered (the dense steps run): the update of an unscented rule with a negative centre
weight (see :func:`update`), the HoMM rules, additive noise, and the dense and SVD forms.
The EKF's
structured covariance steps are :func:`static_tail_cov` and :func:`estimators.ekf.ekf_update`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from scipy.linalg import lapack

from .finite import require_finite
from .linalg import (
    Array,
    NotPositiveDefiniteError,
    chol,
    chol_update,
    chol_update_sweep,
    matvec,
    nis_of,
    solve_lower,
    swap,
    tria,
)
from .models import Innovation, Measurement, SqrtGaussian, Transition
from .rules import CentralDifference, Cubature, Factor, Unscented
from .sigma_points import factorise
from .spaces import Euclidean, Product, Space, Wrapped

__all__ = ["FALLBACKS", "coordinatewise", "dense_steps", "enabled", "flat_rows", "predict",
           "rank_update", "static_tail_cov", "update"]

#: Structured steps that fell back to the dense step, by reason.
FALLBACKS: Counter[str] = Counter()

_STATE = {"enabled": True}
_RULES = (Cubature, Unscented, CentralDifference)
_SQRT_HALF = float(np.sqrt(0.5))


@contextmanager
def dense_steps() -> Iterator[None]:
    """Within this block every sigma-point step is the dense one (the reference path,
    for benchmarks and tests)."""
    before = _STATE["enabled"]
    _STATE["enabled"] = False
    try:
        yield
    finally:
        _STATE["enabled"] = before


def enabled() -> bool:
    """False within :func:`dense_steps`."""
    return _STATE["enabled"]


def static_tail_cov(P: Array, F: Array, G: Array, Qw: Array, h: int) -> Array:
    r"""The EKF's predicted covariance :math:`FPF^\top + GQ_wG^\top` for
    :math:`F = \mathrm{diag}(F_v, I)`, :math:`G = [G_v; 0]` (``F_v`` the first ``h`` rows
    and columns): only the first ``h`` rows and columns change (batched over leading axes)."""
    Fv, Gv = F[..., :h, :h], G[..., :h, :]
    out = np.array(P, dtype=float, copy=True)
    top = Fv @ P[..., :h, :]
    vv = top[..., :, :h] @ swap(Fv) + Gv @ Qw @ swap(Gv)
    out[..., :h, :h] = 0.5 * (vv + swap(vv))
    out[..., :h, h:] = top[..., :, h:]
    out[..., h:, :h] = swap(top[..., :, h:])
    return out


def coordinatewise(space: Space) -> bool:
    """``Euclidean`` or ``Wrapped``: every coordinate moves on its own."""
    return type(space) in (Euclidean, Wrapped)


def flat_rows(space: Space) -> int:
    """How many leading coordinates move on their own (ambient = tangent, each retracted by
    its own ξ row): all of a coordinate-wise space, the leading coordinate-wise parts of a
    :class:`Product`, else 0."""
    if coordinatewise(space):
        return space.dim
    n = 0
    if type(space) is Product:
        for part in space.parts:
            if not coordinatewise(part):
                break
            n += part.dim
    return n


def _head_space(space: Space, h: int) -> Space | None:
    """The space of the first ``h`` coordinates, when the rest are plain Euclidean."""
    if type(space) is Euclidean:
        return Euclidean(h)
    if type(space) is Wrapped and all(a < h for a in space.angles):
        return Wrapped(h, tuple(space.angles))
    return None


def _pairs(rule: Any, C: Array, N: int) -> tuple[Array, Array]:
    """A rule factor's columns by point pair: the columns carrying the pair's deviation
    (tail rows: the augmented factor's column itself) and the rest (tail rows: zero)."""
    if isinstance(rule, CentralDifference):
        return C[..., :N], C[..., N:]
    plus, minus = C[..., :N], C[..., N:]
    return (plus - minus) * _SQRT_HALF, (plus + minus) * _SQRT_HALF


def _pair_index(m: int, N: int, active: Array) -> Array:
    """Index of each of a rule's ``m`` points (``[centre], +e_1..+e_N, -e_1..-e_N``) into a
    reduced set ``[mean, +active, -active]``; inactive points map to the mean (0)."""
    pos = np.zeros(N, dtype=int)
    pos[active] = 1 + np.arange(len(active))
    neg = np.where(pos > 0, pos + len(active), 0)
    head = [0] if m == 2 * N + 1 else []
    return np.concatenate([np.array(head, dtype=int), pos, neg])


def _applies(rule: Any) -> bool:
    return _STATE["enabled"] and type(rule) in _RULES


def predict(rule: Any, belief: SqrtGaussian, model: Transition, u: Any) -> SqrtGaussian | None:
    """The structured prediction (module docstring), or ``None`` when it does not apply
    or failed (counted): the caller then takes the dense step."""
    h, n = model.moves, belief.dim
    if (not _applies(rule) or h is None or model.additive or model.space is not None
            or h > n):
        return None
    head = _head_space(belief.space, h)
    Sq = model.noise.sqrt
    group = (head is None and hasattr(belief.space, "tail_gain")
             and getattr(belief.space, "prefix_rows", None) == h
             and not np.any(belief.sqrt[..., :h, h:]))
    if (head is None and not group) or Sq.shape[-1] != Sq.shape[-2]:
        return None
    try:
        if group:
            return _predict_group(rule, belief, model, u, h)
        return _predict(rule, belief, model, u, h, head)
    except (NotPositiveDefiniteError, np.linalg.LinAlgError) as exc:
        FALLBACKS[f"predict: {exc}"] += 1
        return None


def _reduced_points(rule: Any, belief: SqrtGaussian, model: Transition, u: Any, h: int
                    ) -> tuple[Array, Array, Array, Array]:
    """``(X, Y, wm, active)``: the points ``[mean, +active, -active]`` along the moved and
    noise columns (1 + 2(h + q) of them), their images, the rule's weights and the active
    columns of the augmented factor; checks the ``moves`` declaration."""
    S, mean, space = belief.sqrt, belief.mean, belief.space
    n, q = belief.dim, model.noise.dim
    N = n + q
    xi, wm = rule.points(N)
    c = float(xi[-1, N - 1]) * -1.0  # the spread: the last point is -c e_N
    lead = S.shape[:-2]
    k = h + q
    dev = np.zeros(lead + (1 + 2 * k, n))
    W = np.zeros(lead + (1 + 2 * k, q))
    dev[..., 1:1 + h, :] = c * swap(S[..., :, :h])
    W[..., 1 + h:1 + k, :] = c * swap(model.noise.sqrt)
    dev[..., 1 + k:, :] = -dev[..., 1:1 + k, :]
    W[..., 1 + k:, :] = -W[..., 1:1 + k, :]
    X = space.retract(mean[..., None, :], dev)
    Y = model.f(X, u, W)
    require_finite("transition output", Y)
    if not np.array_equal(Y[..., h:], X[..., h:]):
        raise ValueError(f"transition declares moves={h} but changed a later coordinate")
    return X, Y, wm, np.concatenate([np.arange(h), n + np.arange(q)])


def _predict_group(rule: Any, belief: SqrtGaussian, model: Transition, u: Any, h: int
                   ) -> SqrtGaussian:
    r"""The prediction on a group error (:class:`~estimators.slam_group.SlamGroup`) for a
    motion that moves the pose only (``moves = 3``), module docstring.  A point along a map
    column :math:`k \ge 3` is :math:`\hat x` with its landmarks moved, so its image is
    :math:`\hat y = f(\hat x, u, 0)` with those landmarks moved, and its deviation from
    the new mean :math:`\bar y` is :math:`\ell \pm c\,a \odot S_k` exactly
    (:math:`\ell = \hat y \boxminus \bar y`, :math:`a` the space's ``tail_gain``: one
    complex factor on every landmark pair).  So the rule's factor is that of the reduced
    points (the map points at :math:`\hat y`, which leaves the mean unchanged) with its
    map columns :math:`a \odot S_k` - lower triangular again after one Givens rotation per
    landmark pair (:func:`_tail_block`) - and the other columns (moved, noise, the reduced
    points' sums: every row) are a rank-:math:`(h + r)` update of it: the top ``h`` rows
    by one QR, the rest by :func:`rank_update` of the map block.  Only the factor's
    columns of the moved, noise and one map point pair are formed (:func:`_pair_columns`;
    every map pair's is the same)."""
    S, mean, space = belief.sqrt, belief.mean, belief.space
    n, q = belief.dim, model.noise.dim
    N = n + q
    _, Y, wm, active = _reduced_points(rule, belief, model, u, h)
    index = _pair_index(len(wm), N, active)
    # the map points at ŷ: their weights on ŷ's (the same mean), their deviations ŷ's; the
    # rule's first point first (the heading's chart is taken there)
    order = np.r_[index[0], np.delete(np.arange(Y.shape[-2]), index[0])]
    lumped = np.bincount(index, weights=wm, minlength=Y.shape[-2])
    new_mean = space.mean(Y[..., order, :], lumped[order])
    D = space.local(new_mean[..., None, :], Y)
    k = h + q
    tail = np.zeros(int(n > h), dtype=int)  # a map pair: both points at ŷ (row 0)
    G, rest, c0, sign = _pair_columns(rule, D, N, np.r_[1:1 + k, tail],
                                      np.r_[1 + k:1 + 2 * k, tail])
    E = [G[..., :, :k], rest[..., :, :k]]
    if n > h:  # the map points' sums: one column, the same for every map column
        E.append(np.sqrt(n - h) * rest[..., :, k:])
    if c0 is not None and sign > 0:
        E.append(c0[..., None])
    V = np.concatenate(E, axis=-1)
    Q, R = np.linalg.qr(swap(V[..., :h, :]), mode="complete")
    d = np.where(np.diagonal(R[..., :h, :], axis1=-2, axis2=-1) < 0.0, -1.0, 1.0)[..., None, :]
    out = np.zeros(S.shape)
    out[..., :h, :h] = swap(R[..., :h, :]) * d
    if n > h:
        a = space.tail_gain(mean, new_mean, Y[..., 0, :])
        out[..., h:, :h] = (V[..., h:, :] @ Q[..., :, :h]) * d
        _update_into(out[..., h:, h:], _tail_block(S, a, h), V[..., h:, :] @ Q[..., :, h:])
    if c0 is not None and sign < 0:
        out = chol_update(out, c0, -1.0)
    return SqrtGaussian(new_mean, out, space)


def _pair_columns(rule: Any, D: Array, N: int, plus: Array, minus: Array
                  ) -> tuple[Array, Array, Array | None, float]:
    """:func:`_pairs` of ``rule.factor`` of an ``N``-dimensional rule's full cloud, for
    some point pairs only: ``D`` (..., m, d) the deviations of a reduced cloud whose row 0
    is the rule's centre (its mean for a rule without one), ``plus`` / ``minus`` the rows
    of the pairs' ``+`` and ``-`` points.  Returns ``(G, rest, c0, sign)``: each pair's two
    columns, as :func:`_pairs` gives them, and the rule's signed centre term.  The same
    arithmetic as the full factor's, column by column."""
    Dp, Dm = D[..., plus, :], D[..., minus, :]
    if isinstance(rule, CentralDifference):
        hh = rule.h
        first = (Dp - Dm) / (2.0 * hh)
        second = (Dp + Dm - 2.0 * D[..., :1, :]) * (np.sqrt(hh * hh - 1.0) / (2.0 * hh * hh))
        return swap(first), swap(second), None, 1.0
    c0, sign = None, 1.0
    if isinstance(rule, Unscented):
        w = rule.weights_c(N)
        scale = np.sqrt(w[1])  # every point but the centre has the same weight
        if w[0] != 0.0:
            c0, sign = np.sqrt(abs(w[0])) * D[..., 0, :], float(np.sign(w[0]))
    else:  # Cubature
        scale = np.sqrt(1.0 / (2 * N))
    Cp, Cm = swap(Dp) * scale, swap(Dm) * scale
    return (Cp - Cm) * _SQRT_HALF, (Cp + Cm) * _SQRT_HALF, c0, sign


def _tail_block(S: Array, a: Array, h: int) -> Array:
    r"""The map block of the factor :math:`a \odot S` (rows and columns from ``h``; each
    pair of map rows times the complex factor ``a`` (...,)), each diagonal 2×2 block made
    lower triangular again by one Givens rotation of its column pair (all pairs at once;
    non-negative diagonal): a fresh C-ordered (..., n - h, n - h) array, what
    ``lower_factor`` makes of those rows and columns."""
    Sm = S[..., h:, h:]
    ar, ai = a.real[..., None, None], a.imag[..., None, None]
    x, y = Sm[..., 0::2, :], Sm[..., 1::2, :]
    M = np.empty(Sm.shape)
    top, bottom = M[..., 0::2, :], M[..., 1::2, :]
    np.multiply(x, ar, out=top)
    top -= y * ai
    np.multiply(x, ai, out=bottom)
    bottom += y * ar
    i = np.arange(0, M.shape[-1], 2)
    saa, sab = M[..., i, i], M[..., i, i + 1]
    r = np.hypot(saa, sab)
    c = np.divide(saa, r, out=np.ones_like(r), where=r > 0.0)[..., None, :]
    s = np.divide(sab, r, out=np.zeros_like(r), where=r > 0.0)[..., None, :]
    ca, cb = M[..., :, 0::2], M[..., :, 1::2]
    new_a = ca * c
    new_a += cb * s
    cb *= c
    cb -= ca * s
    ca[...] = new_a
    M[..., i, i + 1] = 0.0
    neg = M[..., i + 1, i + 1] < 0.0
    if neg.any():
        M[..., :, 1::2] *= np.where(neg, -1.0, 1.0)[..., None, :]
    return M


def _predict(rule: Any, belief: SqrtGaussian, model: Transition, u: Any, h: int,
             head: Space) -> SqrtGaussian:
    S, mean, space = belief.sqrt, belief.mean, belief.space
    n, q = belief.dim, model.noise.dim
    N = n + q
    _, Y, wm, active = _reduced_points(rule, belief, model, u, h)
    lead = S.shape[:-2]
    Yh = Y[..., _pair_index(len(wm), N, active), :h]
    mean_h = head.mean(Yh, wm)
    fac = rule.factor(head.local(mean_h[..., None, :], Yh))
    G, rest = _pairs(rule, fac.C, N)
    E = [G[..., n:], rest]
    if fac.c0 is not None and fac.sign > 0:
        E.append(fac.c0[..., None])
    Ec = tria(np.concatenate(E, axis=-1))
    Q, R = np.linalg.qr(np.concatenate([swap(G[..., :h]), swap(Ec)], axis=-2), mode="complete")
    d = np.where(np.diagonal(R[..., :h, :], axis1=-2, axis2=-1) < 0.0, -1.0, 1.0)[..., None, :]
    out = np.zeros(S.shape)
    out[..., :h, :h] = swap(R[..., :h, :]) * d
    if n > h:
        B = S[..., h:, :h]
        out[..., h:, :h] = B @ (Q[..., :h, :h] * d)
        _update_into(out[..., h:, h:], np.array(S[..., h:, h:], order="C", copy=True),
                     B @ Q[..., :h, h:])
    if fac.c0 is not None and fac.sign < 0:
        c0 = np.zeros(lead + (n,))
        c0[..., :h] = fac.c0
        out = chol_update(out, c0, -1.0)
    new_mean = np.concatenate([mean_h, mean[..., h:]], axis=-1)
    return SqrtGaussian(new_mean, out, space)


def update(rule: Any, belief: SqrtGaussian, model: Measurement, z: Array
           ) -> tuple[SqrtGaussian, Innovation] | None:
    """The structured update (module docstring), or ``None`` when it does not apply or its
    Potter factor failed (counted): the caller then takes the dense step.  An innovation
    covariance that is not positive definite raises as the dense step does.  Not for an
    unscented rule with a negative centre weight: the dense step's posterior is then a
    factor and a downdate, which can fail where :math:`SS^\top - UU^\top` does not, and
    the two must fail alike."""
    if not _applies(rule) or model.reads is None:
        return None
    n = belief.dim
    a = max(model.reads) + 1
    if a > n or (isinstance(rule, Unscented) and rule.weights_c(n)[0] < 0.0):
        return None
    prefix = getattr(belief.space, "prefix_rows", None)  # e.g. SlamGroup's
    if not (a <= flat_rows(belief.space) or (prefix is not None and a >= prefix)):
        return None
    S, mean, space = belief.sqrt, belief.mean, belief.space
    if model.selects and type(model.space) is Euclidean:  # h(x) = x[reads]: Kalman's update
        rows = list(model.reads)  # type: ignore[arg-type]
        Gz = S[..., rows, :a]
        nu = np.asarray(z, dtype=float) - mean[..., rows]
        Szz = factorise("sqrt", Factor(Gz), model.noise.sqrt)
    else:
        Gz, nu, Szz = _points_read(rule, belief, model, z, a)
    if not np.all(np.diagonal(Szz, axis1=-2, axis2=-1) > 0.0):
        raise NotPositiveDefiniteError("innovation covariance is singular")
    Wa = swap(solve_lower(Szz, Gz))
    w = solve_lower(Szz, nu)
    try:
        La = chol(np.eye(a) - Wa @ swap(Wa))
    except NotPositiveDefiniteError:
        FALLBACKS["update: I - W Wᵀ of the Potter update is not positive definite in "
                  "floating point"] += 1
        return None
    Sa = S[..., :, :a]
    post = np.array(S, dtype=float, copy=True)
    post[..., :, :a] = Sa @ La
    new = SqrtGaussian(space.retract(mean, matvec(Sa, matvec(Wa, w))), post, space)
    return new, Innovation(nu, Szz, nis_of(w))


def _points_read(rule: Any, belief: SqrtGaussian, model: Measurement, z: Array, a: int
                 ) -> tuple[Array, Array, Array]:
    """``(G_z, ν, S_zz)`` of the update from the ``2a + 1`` points along the read columns."""
    S, mean, n = belief.sqrt, belief.mean, belief.dim
    xi, wm = rule.points(n)
    c = -float(xi[-1, n - 1])
    dev = np.zeros(S.shape[:-2] + (1 + 2 * a, n))
    dev[..., 1:1 + a, :] = c * swap(S[..., :, :a])
    dev[..., 1 + a:, :] = -dev[..., 1:1 + a, :]
    Z = model.h(belief.space.retract(mean[..., None, :], dev))
    require_finite("measurement model output", Z)
    # the points after column a are all at the mean (row 0): their weights lumped on it
    # (the rule's first point first: the chart's reference), their pairs one column
    index = _pair_index(len(wm), n, np.arange(a))
    order = np.r_[index[0], np.delete(np.arange(Z.shape[-2]), index[0])]
    lumped = np.bincount(index, weights=wm, minlength=Z.shape[-2])
    zspace = model.space
    zhat = zspace.mean(Z[..., order, :], lumped[order])
    tail = np.zeros(int(n > a), dtype=int)
    G, rest, c0, sign = _pair_columns(rule, zspace.local(zhat[..., None, :], Z), n,
                                      np.r_[1:1 + a, tail], np.r_[1 + a:1 + 2 * a, tail])
    C = [G[..., :a], rest[..., :a]]
    if n > a:
        C.append(np.sqrt(n - a) * rest[..., a:])
    nu = zspace.local(zhat, np.asarray(z, dtype=float))
    Szz = factorise("sqrt", Factor(np.concatenate(C, axis=-1), c0, sign), model.noise.sqrt)
    return G[..., :a], nu, Szz


def rank_update(C: Array, V: Array) -> Array:
    r"""Lower factor of :math:`C C^\top + V V^\top` for a lower-triangular ``C`` (..., n, n)
    and ``V`` (..., n, k): the Householder row sweep of :func:`chol_update_sweep` (LAPACK
    ``dtpqrt``, :math:`O(k n^2)`), member by member for a batch (each member's rows, C
    order, are its transpose's columns, Fortran order: no copies per member)."""
    if C.ndim == 2:
        return chol_update_sweep(C, V, 1.0)
    lead = np.broadcast_shapes(C.shape[:-2], V.shape[:-2])
    n, k = C.shape[-1], V.shape[-1]
    L = np.array(np.broadcast_to(C, lead + (n, n)), dtype=float, order="C", copy=True)
    X = np.array(np.broadcast_to(V, lead + (n, k)), dtype=float, order="C", copy=True)
    out = np.empty(L.shape)
    _update_into(out, L, X)
    return out


def _update_into(out: Array, L: Array, X: Array) -> None:
    """``out[...] =`` :func:`rank_update` ``(L, X)``, overwriting ``L`` and ``X`` (fresh
    arrays the caller owns, C-ordered; an unbatched ``L`` takes
    :func:`chol_update_sweep`)."""
    if L.ndim == 2:
        out[...] = chol_update_sweep(L, X, 1.0)
        return
    n = L.shape[-1]
    if not (L.flags.c_contiguous and X.flags.c_contiguous):
        raise ValueError("the sweep works in place on C-ordered arrays")
    L2, X2 = L.reshape(-1, n, n), X.reshape(-1, n, X.shape[-1])
    nb = max(1, min(16, n))
    for i in range(L2.shape[0]):
        R, _, _, info = lapack.dtpqrt(0, nb, L2[i].T, X2[i].T, overwrite_a=1, overwrite_b=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"triangular-pentagonal QR failed (info {info})")
        L2[i] = R.T
    d = np.diagonal(L, axis1=-2, axis2=-1)
    np.multiply(L, np.where(d < 0.0, -1.0, 1.0)[..., None, :], out=out)
