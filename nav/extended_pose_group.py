r"""The extended-pose SLAM group :math:`SE_{2+n}(3)` with IMU biases beside it, as a state
space: the "imperfect" invariant error of a strapdown SLAM filter (Barrau & Bonnabel 2017,
"The invariant extended Kalman filter as a stable observer"; on sigma points: Brossard,
Barrau & Bonnabel 2020, "A code for unscented Kalman filtering on manifolds").

A state - attitude :math:`R = C(q_{nb})`, velocity :math:`v`, position :math:`p`, landmarks
:math:`m_1 \dots m_n` - is the group element

.. math::

    X = \begin{bmatrix} R & v & p & m_1 & \cdots & m_n \\ 0 & & I_{2+n} & & \end{bmatrix}
    \in SE_{2+n}(3),

and the biases :math:`b` (``n_bias`` numbers) stay outside the group with additive error.
Ambient coordinates are the strapdown SLAM state ``[p, v, q (Hamilton, scalar first), b,
m_1, ..., m_n]`` and tangent coordinates are in the same order, :math:`ξ = [ξ_p, ξ_v, ξ_θ,
δb, ξ_{m_1}, \dots]`, so models, slices and scores written for that state still apply.
With :math:`\mathrm{Exp}` the SO(3) exponential and :math:`J_l` its left Jacobian,
:math:`\exp(ξ) = (\mathrm{Exp}\,ξ_θ,\ J_l(ξ_θ) ξ_v,\ J_l(ξ_θ) ξ_p,\ J_l(ξ_θ) ξ_{m_i})`.

``side = "right"`` (right-invariant error, the default): :math:`x \boxplus ξ = \exp(ξ) X`,

.. math::

    R' = \mathrm{Exp}(ξ_θ) R,\quad u' = \mathrm{Exp}(ξ_θ)\,u + J_l(ξ_θ)\,ξ_u
    \quad (u = v, p, m_i),\quad b' = b + δb,

and :math:`y \boxminus x = \log(Y X^{-1})`.  A rotation of the whole scene about the origin
is :math:`ξ = (0, 0, α, 0, \dots)` and a common translation :math:`ξ_p = ξ_{m_i} = t` at
every estimate.  ``side = "left"``: :math:`x \boxplus ξ = X \exp(ξ)`,
:math:`y \boxminus x = \log(X^{-1} Y)`.

:meth:`ExtendedPoseGroup.to_world` applies :math:`M = \partial(\text{standard error of }
x \boxplus ξ)/\partial ξ|_0`, the standard error being ``[δp, δv, δθ_body, δb, δm]`` with
:math:`q = \hat q \otimes \mathrm{Exp}(δθ)`.  Right: :math:`δθ = R^\top ξ_θ`,
:math:`δu = ξ_u - [u]_\times ξ_θ`; left: :math:`δθ = ξ_θ`, :math:`δu = R ξ_u`.

Quaternion formulas are :mod:`nav.quaternion`'s (the unit DCM :func:`nav.strapdown.dcm_unit`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np

from estimators.group_transport import WorldChartGroup
from estimators.linalg import Array
from estimators.spaces import MeanNotConvergedError

from .quaternion import qconj, qexp, qleft_matrix, qlog, qmul, qright_matrix, skew
from .strapdown import dcm_unit as qdcm

Side = Literal["right", "left"]

#: Below this angle the SO(3) coefficients use their Taylor series (truncation < 3e-17).
_SERIES = 0.1
_EPS = float(np.finfo(float).eps)


# --------------------------------------------------------------------------- SO(3) kit

def _T(A: Array) -> Array:
    """Batched transpose of matrices (..., i, j)."""
    return np.swapaxes(A, -1, -2)


#: Scalar functions of :math:`t = |φ|`: Taylor coefficients of :math:`1, t^2, \dots, t^8`
#: and the closed form (used for :math:`t \ge` :data:`_SERIES`).
_FUNCTIONS: dict[str, tuple[tuple[float, ...], Callable[[Array], Array]]] = {
    "cos": ((1.0, -1 / 2, 1 / 24, -1 / 720, 1 / 40320), np.cos),
    "sinc": ((1.0, -1 / 6, 1 / 120, -1 / 5040, 1 / 362880), lambda t: np.sin(t) / t),
    "a": ((1 / 2, -1 / 24, 1 / 720, -1 / 40320, 1 / 3628800),
          lambda t: (1.0 - np.cos(t)) / (t * t)),
    "b": ((1 / 6, -1 / 120, 1 / 5040, -1 / 362880, 1 / 39916800),
          lambda t: (t - np.sin(t)) / t**3),
    "tcot": ((1.0, -1 / 12, -1 / 720, -1 / 30240, -1 / 1209600),
             lambda t: 0.5 * t / np.tan(0.5 * t)),
    "c": ((1 / 12, 1 / 720, 1 / 30240, 1 / 1209600, 1 / 47900160),
          lambda t: (1.0 - 0.5 * t / np.tan(0.5 * t)) / (t * t)),
    "-1/2": ((-0.5, 0.0, 0.0, 0.0, 0.0), lambda t: np.full_like(t, -0.5)),
    "qw": ((1.0, -1 / 8, 1 / 384, -1 / 46080, 1 / 10321920), lambda t: np.cos(0.5 * t)),
    "qk": ((1 / 2, -1 / 48, 1 / 3840, -1 / 645120, 1 / 185794560),
           lambda t: np.sin(0.5 * t) / t),
}

#: Each SO(3) matrix as :math:`c_I I + c_\times [φ]_\times + c_{φφ} φφ^\top`: the functions
#: giving its three coefficients (:math:`[φ]_\times^2 = φφ^\top - t^2 I`).
_MATRICES: dict[str, tuple[str, str, str]] = {
    "exp": ("cos", "sinc", "a"),        # Exp(φ) = I + sinc [φ]x + a [φ]x²  (Rodrigues)
    "jl": ("sinc", "a", "b"),           # J_l(φ) = I + a [φ]x + b [φ]x²
    "jl_inv": ("tcot", "-1/2", "c"),    # J_l(φ)⁻¹ = I - ½ [φ]x + c [φ]x²
}
#: :math:`\mathrm{Exp}(φ)` as a quaternion, :math:`[\cos\tfrac t2, \tfrac1t\sin\tfrac t2\,φ]`.
_QUAT = ("qw", "qk")
_POWERS = np.arange(5.0)


#: (13, 9): rows ``vec(I)``, ``vec([e_k]×)`` and the unit matrices, so that
#: ``[c_I, c_× φ, c_φφ vec(φφᵀ)] @ _BASIS = vec(c_I I + c_× [φ]× + c_φφ φφᵀ)``.
_BASIS = np.vstack([np.eye(3).reshape(1, 9), skew(np.eye(3)).reshape(3, 9), np.eye(9)])
_BASIS.setflags(write=False)
_SKEW = _BASIS[1:4]                      # φ @ _SKEW = vec([φ]x)
_GROUP = np.array([0, 1, 1, 1] + [2] * 9)  # which coefficient scales each basis row


@lru_cache(maxsize=16)
def _coefficient_names(kinds: tuple[str, ...], scalars: tuple[str, ...]) -> tuple[str, ...]:
    """The functions giving :func:`so3_coefficients`' columns."""
    return tuple(_MATRICES[k][g] for k in kinds for g in _GROUP) + scalars


@lru_cache(maxsize=16)
def _series_table(names: tuple[str, ...]) -> Array:
    """(5, len(names)) Taylor coefficients of the functions ``names``."""
    table = np.array([_FUNCTIONS[f][0] for f in names]).T
    table.setflags(write=False)
    return table


def so3_coefficients(t2: Array, kinds: tuple[str, ...], scalars: tuple[str, ...] = ()
                     ) -> Array:
    r"""(..., 13K + S): for each matrix of ``kinds`` (keys of :data:`_MATRICES`) its
    coefficient of each row of :data:`_BASIS`, :math:`(c_I, c_\times, c_\times, c_\times,
    c_{φφ}, \dots)`, then the functions ``scalars`` (keys of :data:`_FUNCTIONS`), at
    squared angles ``t2``: Taylor series below :data:`_SERIES` (where the closed forms
    cancel), closed forms above; every coefficient is finite up to and at :math:`t = π`."""
    t2 = np.asarray(t2, dtype=float)
    names = _coefficient_names(kinds, scalars)
    series = (t2[..., None] ** _POWERS) @ _series_table(names)
    if t2.max(initial=0.0) < _SERIES * _SERIES:
        return series
    small = t2 < _SERIES * _SERIES
    t = np.sqrt(np.where(small, 1.0, t2))
    closed = {f: _FUNCTIONS[f][1](t) for f in set(names)}
    return np.where(small[..., None], series, np.stack([closed[f] for f in names], axis=-1))


def so3_kit(phi: Array, kinds: tuple[str, ...], scalars: tuple[str, ...] = ()
            ) -> tuple[Array, Array]:
    r"""The matrices ``kinds`` at rotation vectors ``phi`` (..., 3), as (..., K, 3, 3):
    ``"exp"`` :math:`\mathrm{Exp}(φ)`, ``"jl"`` :math:`J_l(φ)`, ``"jl_inv"``
    :math:`J_l(φ)^{-1}` (:data:`_MATRICES`), all from one product of the features
    :math:`[1, φ, \mathrm{vec}(φφ^\top)]`, scaled by their coefficients, with
    :data:`_BASIS`; and the functions ``scalars`` of :math:`|φ|` (..., S)."""
    phi = np.asarray(phi, dtype=float)
    lead, K = phi.shape[:-1], len(kinds)
    F = np.empty(lead + (13,))
    F[..., 0] = 1.0
    F[..., 1:4] = phi
    F[..., 4:] = (phi[..., :, None] * phi[..., None, :]).reshape(lead + (9,))
    C = so3_coefficients(F[..., 4] + F[..., 8] + F[..., 12], kinds, scalars)
    W = C[..., :13 * K].reshape(lead + (K, 13)) * F[..., None, :]
    return (W.reshape(-1, 13) @ _BASIS).reshape(lead + (K, 3, 3)), C[..., 13 * K:]


def jl_matrix(phi: Array, inverse: bool = False) -> Array:
    r""":math:`J_l(φ) = I + a[φ]_\times + b[φ]_\times^2` or
    :math:`J_l(φ)^{-1} = I - \tfrac12[φ]_\times + c[φ]_\times^2` as matrices (..., 3, 3),
    with :math:`a = (1 - \cos t)/t^2`, :math:`b = (t - \sin t)/t^3`,
    :math:`c = (1 - \tfrac t2\cot\tfrac t2)/t^2` (:func:`so3_kit`)."""
    return so3_kit(phi, ("jl_inv" if inverse else "jl",))[0][..., 0, :, :]


def jl_apply(phi: Array, u: Array, inverse: bool = False) -> Array:
    r""":math:`J_l(φ) u` (or :math:`J_l(φ)^{-1} u`) for rotation vectors ``phi`` (..., 3) and
    vectors ``u`` (..., k, 3), batched over ``...``."""
    return np.matmul(u, _T(jl_matrix(phi, inverse)))


def _qprod(p: Array, q: Array) -> Array:
    """:func:`~nav.quaternion.qmul` ``p ⊗ q``, as one matrix product when ``p`` or ``q``
    is a single quaternion (the other a batch)."""
    if q.ndim == 1:
        return p @ qright_matrix(q).T
    if p.ndim == 1:
        return q @ qleft_matrix(p).T
    return qmul(p, q)


def _rotate(u: Array, R: Array) -> Array:
    """``u @ Rᵀ`` batched; for one set of vectors ``u`` (k, 3) and rotations ``R``
    (m, 3, 3) as one matrix product (``np.matmul`` of small stacks is several times
    slower)."""
    if u.ndim != 2 or R.ndim != 3:
        return np.matmul(u, _T(R))
    m = R.shape[0]
    return (R.reshape(3 * m, 3) @ u.T).reshape(m, 3, -1).transpose(0, 2, 1)

# --------------------------------------------------------------------------- the space


@dataclass(frozen=True)
class ExtendedPoseGroup(WorldChartGroup):
    """:math:`SE_{2+n}(3)` × biases (module docstring); a :class:`~estimators.spaces.Space`
    on ``[p, v, q, b, m_1, ..., m_n]`` with ``n_landmarks`` 3-D landmarks and ``n_bias``
    bias coordinates.  Vectorised over points (rows) and the :math:`2 + n` vectors: the
    vectors are the columns ``0:6`` and the landmark columns (ambient from
    ``10 + n_bias``, tangent from ``9 + n_bias``), read and written as slices."""

    n_landmarks: int
    side: Side = "right"
    n_bias: int = 6
    tol: float = 1e-13
    max_iter: int = 50

    def __post_init__(self) -> None:
        if self.side not in ("right", "left"):
            raise ValueError(f"side must be 'right' or 'left', not {self.side!r}")

    @property
    def ambient_dim(self) -> int:
        return 10 + self.n_bias + 3 * self.n_landmarks

    @property
    def dim(self) -> int:
        return 9 + self.n_bias + 3 * self.n_landmarks

    @property
    def _bias(self) -> tuple[slice, slice]:
        return slice(10, 10 + self.n_bias), slice(9, 9 + self.n_bias)

    def _vectors(self, a: Array, start: int) -> Array:
        """(..., 2 + n, 3) vectors of rows ``a`` whose landmarks start at column ``start``."""
        return np.concatenate([a[..., :6], a[..., start:]], axis=-1).reshape(
            a.shape[:-1] + (2 + self.n_landmarks, 3))

    def _put(self, out: Array, vecs: Array, start: int) -> None:
        """Write vectors (..., 2 + n, 3) into rows ``out`` (landmarks from ``start``)."""
        flat = vecs.reshape(vecs.shape[:-2] + (-1,))
        out[..., :6] = flat[..., :6]
        out[..., start:] = flat[..., 6:]

    @staticmethod
    def _rows(rot: Array, vecs: Array, b: Array) -> Array:
        """Ambient rows ``[p, v, q, b, m_1, ...]`` (``rot`` quaternions) or tangent rows
        ``[ξ_p, ξ_v, ξ_θ, δb, ξ_m, ...]`` (``rot`` rotation vectors) of ``vecs``, all
        with the same batch shape."""
        flat = vecs.reshape(vecs.shape[:-2] + (-1,))
        return np.concatenate([flat[..., :6], rot, b, flat[..., 6:]], axis=-1)

    def exp(self, xi: Array) -> Array:
        """Ambient coordinates of :math:`\\exp(ξ)` (biases: ``δb``)."""
        xi = np.asarray(xi, dtype=float)
        th = xi[..., 6:9]
        return self._rows(qexp(th), jl_apply(th, self._vectors(xi, 9 + self.n_bias)),
                          xi[..., self._bias[1]])

    def log(self, x: Array) -> Array:
        """Inverse of :meth:`exp` (rotation angle in ``[0, π]``)."""
        x = np.asarray(x, dtype=float)
        th = qlog(x[..., 6:10])
        u = jl_apply(th, self._vectors(x, 10 + self.n_bias), inverse=True)
        return self._rows(th, u, x[..., self._bias[0]])

    def retract(self, x: Array, delta: Array) -> Array:
        x, d = np.asarray(x, dtype=float), np.asarray(delta, dtype=float)
        if self.side == "right" and x.ndim == 1 and d.ndim == 2:
            turn = (d[:, 6:9] != 0.0).any(axis=1)
            if not turn.all():   # Exp(0) = I, J_l(0) = I: Exp(ξ)X translates every vector
                out = np.concatenate([d[:, :6], np.zeros((len(d), 4)), d[:, 9:]], axis=1) + x
                if turn.any():
                    out[turn] = self._retract(x, d[turn])
                return out
        return self._retract(x, d)

    def _retract(self, x: Array, d: Array) -> Array:
        th, q, nb, right = d[..., 6:9], x[..., 6:10], self.n_bias, self.side == "right"
        u, xi = self._vectors(x, 10 + nb), self._vectors(d, 9 + nb)
        M, s = so3_kit(th, ("exp", "jl") if right else ("jl",), _QUAT)
        dq = np.concatenate([s[..., :1], s[..., 1:] * th], axis=-1)    # Exp(ξ_θ)
        Jxi = np.matmul(xi, _T(M[..., -1, :, :]))                      # J_l(ξ_θ) ξ_u
        if right:                  # exp(ξ) X: Exp(ξ_θ) u + J_l(ξ_θ) ξ_u
            qn, new = _qprod(dq, q), _rotate(u, M[..., 0, :, :]) + Jxi
        else:                      # X exp(ξ): u + R J_l(ξ_θ) ξ_u
            qn, new = _qprod(q, dq), u + np.matmul(Jxi, _T(qdcm(q)))
        qn /= np.sqrt((qn * qn).sum(axis=-1, keepdims=True))     # qn: a new array
        return self._rows(qn, new, x[..., self._bias[0]] + d[..., self._bias[1]])

    def local(self, x: Array, y: Array) -> Array:
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        qx, qy = x[..., 6:10], y[..., 6:10]
        ux, uy = self._vectors(x, 10 + self.n_bias), self._vectors(y, 10 + self.n_bias)
        if self.side == "right":   # log(Y X⁻¹): J_l(θ)⁻¹ (u_y - Exp(θ) u_x)
            th, EJ = _CLOUD.get(qx, qy) or _attitude_errors(qy, qx)
            du = uy - _rotate(ux, EJ[..., 0, :, :])
            Ji = EJ[..., 1, :, :]
        else:                      # log(X⁻¹ Y): J_l(θ)⁻¹ R_xᵀ (u_y - u_x)
            th = qlog(_qprod(qconj(qx), qy))
            du = np.matmul(uy - ux, qdcm(qx))
            Ji = jl_matrix(th, inverse=True)
        db = y[..., self._bias[0]] - x[..., self._bias[0]]
        return self._rows(th, np.matmul(du, _T(Ji)), db)

    def _attitude_mean(self, qs: Array, w: Array) -> Array:
        """Weighted Karcher mean of unit quaternions (m, 4) by fixed-point iteration from
        the sign-aligned chordal mean; the same point for either side (bi-invariant)."""
        ref = qs[int(np.argmax(w))]
        q = w @ (qs * np.where(qs @ ref < 0.0, -1.0, 1.0)[:, None])
        q = q / np.sqrt(q @ q)
        floor = 8.0 * _EPS * float(np.abs(w).sum())
        prev = step_n = np.inf
        for _ in range(self.max_iter):
            step = w @ qlog(qs @ qleft_matrix(qconj(q)).T)   # Σ wᵢ Log(q̄* ⊗ qᵢ)
            q = qleft_matrix(q) @ qexp(step)
            q = q / np.sqrt(q @ q)
            step_n = float(np.sqrt(step @ step))
            if step_n < self.tol or (step_n <= floor and step_n > 0.5 * prev):
                return q
            prev = step_n
        raise MeanNotConvergedError(f"attitude mean did not converge in {self.max_iter} "
                                    f"iterations (last step {step_n:.3e} rad)")

    def mean(self, points: Array, weights: Array) -> Array:
        r"""The group barycentre :math:`\sum_i w_i (x_i \boxminus \bar x) = 0`; biases: the
        weighted mean.  The attitude part only involves :math:`\bar R` (the Karcher mean);
        given :math:`\bar R`, with :math:`φ_i` the attitude error of point :math:`i` and
        :math:`J_i = J_l(φ_i)^{-1}`, every vector part is linear in :math:`\bar u`:

        .. math::

            \text{right: } \Big(\sum_i w_i J_i ΔR_i\Big)\bar u = \sum_i w_i J_i u_i,
            \ ΔR_i = R_i\bar R^\top;\qquad
            \text{left: } \Big(\sum_i w_i J_i\Big)\bar R^\top \bar u
            = \sum_i w_i J_i \bar R^\top u_i,

        one 3 × 3 solve for all :math:`2 + n` vectors.  Right: since
        :math:`J_l(φ)^{-1}\mathrm{Exp}(φ) = J_l(φ)^{-1} + [φ]_\times` the matrix is
        :math:`\sum_i w_i J_i + [\sum_i w_i φ_i]_\times` (the bracket vanishes up to the
        attitude iteration's tolerance).  A singular system (a cloud spread over ~π)
        raises :class:`MeanNotConvergedError`.
        """
        pts = np.asarray(points, dtype=float)
        w = np.asarray(weights, dtype=float)
        qbar = self._attitude_mean(pts[:, 6:10], w)
        u = self._vectors(pts, 10 + self.n_bias)                 # (m, k, 3)
        right = self.side == "right"
        if right:                  # φᵢ, Exp(φᵢ), Jᵢ, kept for local(mean, points)
            phi, EJ = _CLOUD.put(pts[:, 6:10], qbar, *_attitude_errors(pts[:, 6:10], qbar))
            J = EJ[:, 1] * w[:, None, None]                     # wᵢ Jᵢ
            A = J.sum(axis=0) + ((w @ phi) @ _SKEW).reshape(3, 3)
            rhs = _sum_products(u, _T(J))
        else:
            J = jl_matrix(qlog(_qprod(qconj(qbar), pts[:, 6:10])), inverse=True) * w[:, None, None]
            Rbar = qdcm(qbar)
            A, rhs = J.sum(axis=0), _sum_products(u @ Rbar, _T(J))
        _require_regular(A)
        ubar = np.linalg.solve(A, rhs.T).T
        if not right:
            ubar = ubar @ Rbar.T
        return self._rows(qbar, ubar, w @ pts[:, self._bias[0]])

    # ----------------------------------------------------------------- the world chart

    def to_world(self, x: Array, A: Array) -> Array:
        r""":math:`M A`, :math:`M = \partial(\mathrm{std}(x \boxplus ξ) \boxminus_{std} x)
        /\partial ξ|_0` at one point ``x``, for a tangent-row matrix ``A`` (d, m), e.g. a
        covariance factor (:math:`P_w = M P M^\top`).  Right: :math:`M = I` except
        :math:`M_{θθ} = R^\top` and :math:`M_{uθ} = -[u]_\times`; left:
        :math:`M = \mathrm{blkdiag}(R, R, I_3, I_b, R, \dots)`.  By blocks, never (d, d)."""
        return self._apply(x, A, inverse=False)

    def from_world(self, x: Array, A: Array) -> Array:
        r""":math:`M^{-1} A` (:meth:`to_world`); right: :math:`ξ_θ = R δθ`,
        :math:`ξ_u = δu + [u]_\times R δθ`."""
        return self._apply(x, A, inverse=True)

    def _skews(self, x: Array) -> Array:
        r"""(3(2 + n), 3): the :math:`[u]_\times` of the vectors of one point, stacked."""
        return (self._vectors(x, 10 + self.n_bias) @ _SKEW).reshape(-1, 3)

    def _apply(self, x: Array, A: Array, inverse: bool) -> Array:
        x, A = np.asarray(x, dtype=float), np.asarray(A, dtype=float)
        R, s = qdcm(x[6:10]), 9 + self.n_bias
        out = A.copy()
        if self.side == "right":   # rows u: ∓[u]x ξ_θ, ξ_θ the rotation rows of A or out
            th = R @ A[6:9] if inverse else R.T @ A[6:9]
            out[6:9] = th
            corr = self._skews(x) @ (th if inverse else -A[6:9])
            out[:6] += corr[:6]
            out[s:] += corr[6:]
            return out
        # left: δu = R ξ_u; the columns of A (a vector A: itself) as rows
        self._put(out.T, self._vectors(A.T, s) @ (R if inverse else R.T), s)
        return out

    def right_world(self, x: Array, B: Array) -> Array:
        r""":math:`B M` for ``B`` (r, d) with tangent columns: a Jacobian in the standard
        chart carried to the group's error (right: column block θ becomes
        :math:`B_θ R^\top - \sum_u B_u [u]_\times`)."""
        x, B = np.asarray(x, dtype=float), np.asarray(B, dtype=float)
        R = qdcm(x[6:10])
        out = B.copy()
        if self.side == "right":
            s, S = 9 + self.n_bias, self._skews(x)
            out[:, 6:9] = B[:, 6:9] @ R.T - (B[:, :6] @ S[:6] + B[:, s:] @ S[6:])
            return out
        self._put(out, self._vectors(B, 9 + self.n_bias) @ R, 9 + self.n_bias)
        return out

    @property
    def transport_lead(self) -> int:
        r"""Right error: :math:`T` rotates the attitude rows by :math:`R_{new}^\top R_{old}`
        and adds multiples of them to the p, v and landmark rows, so in a lower factor it
        touches columns 0-8 alone.  Implemented for the right error only."""
        if self.side != "right":
            raise ValueError("the covariance transport is implemented for the right error")
        return 9

    def transport_columns(self, x_old: Array, x_new: Array) -> Array:
        r""":math:`T - I` on the first :attr:`transport_lead` columns,
        :math:`T = M(x_{new}) M(x_{old})^{-1}`: only the rotation columns move, by
        :math:`R_{new}^\top R_{old} - I` in the rotation rows and by
        :math:`[u_{old} - u_{new}]_\times R_{old}` in each vector's rows."""
        Ro, s = qdcm(x_old[6:10]), 9 + self.n_bias
        E = np.zeros((self.dim, self.transport_lead))
        E[6:9, 6:9] = qdcm(x_new[6:10]).T @ Ro - np.eye(3)
        C = self._skews(np.asarray(x_old) - x_new) @ Ro
        E[:6, 6:9], E[s:, 6:9] = C[:6], C[6:]
        return E


def _attitude_errors(qs: Array, qbar: Array) -> tuple[Array, Array]:
    r"""Right attitude errors :math:`φ_i = \mathrm{Log}(q_i \otimes \bar q^*)` of quaternions
    ``qs`` (m, 4) from ``qbar``, and (m, 2, 3, 3) :math:`\mathrm{Exp}(φ_i)`,
    :math:`J_l(φ_i)^{-1}`."""
    phi = qlog(_qprod(qs, qconj(qbar)))
    return phi, so3_kit(phi, ("exp", "jl_inv"))[0]


class _CloudMemo:
    """The last cloud's :func:`_attitude_errors`: a filter asks for ``local(mean, points)``
    right after ``mean(points)``, which needs the same errors.  :meth:`get` returns them
    only for quaternions equal to those stored (so exactly what recomputing gives);
    stored arrays are copies, returned ones read-only."""

    last: tuple[Array, ...] = ()

    def put(self, qs: Array, qbar: Array, phi: Array, EJ: Array) -> tuple[Array, Array]:
        phi.setflags(write=False)
        EJ.setflags(write=False)
        self.last = (qs.copy(), qbar.copy(), phi, EJ)
        return phi, EJ

    def get(self, qbar: Array, qs: Array) -> tuple[Array, Array] | None:
        last = self.last
        hit = (bool(last) and qbar.shape == (4,) and qs.shape == last[0].shape
               and np.array_equal(qbar, last[1]) and np.array_equal(qs, last[0]))
        return (last[2], last[3]) if hit else None


_CLOUD = _CloudMemo()


def _sum_products(A: Array, B: Array) -> Array:
    r""":math:`\sum_i A_i B_i` for stacks (m, a, 3) and (m, 3, b), as one matrix product."""
    m, a, _ = A.shape
    return A.transpose(1, 0, 2).reshape(a, 3 * m) @ B.reshape(3 * m, -1)


def _require_regular(A: Array) -> None:
    """Raise :class:`MeanNotConvergedError` unless the barycentre matrix ``A`` (3, 3) is
    finite with condition number below 1e8.  Skips the SVD when
    :math:`\\lVert A - I\\rVert_F < 1/2` (singular values in :math:`[1/2, 3/2]`, so the
    condition number is at most 3): the usual case, a cloud spread well below π."""
    dev = A - np.eye(3)
    if float(np.sum(dev * dev)) < 0.25:
        return
    if not (np.all(np.isfinite(A)) and np.linalg.cond(A) < 1e8):
        raise MeanNotConvergedError("group mean undefined (singular barycentre system)")


def chain_jacobians(space_in: ExtendedPoseGroup, space_out: ExtendedPoseGroup, x: Array,
                    y: Array, F: Array, G: Array | None = None
                    ) -> tuple[Array, Array | None]:
    r"""A transition's standard-chart Jacobians in the group's error by the chain rule:
    :math:`F_ξ = M(y)^{-1} F M(x)`, :math:`G_ξ = M(y)^{-1} G` (``x`` the input mean,
    ``y = f(x)``)."""
    Fx = space_out.from_world(y, space_in.right_world(x, F))
    return Fx, None if G is None else space_out.from_world(y, G)
