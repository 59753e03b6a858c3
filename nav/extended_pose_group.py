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

from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np

from estimators.group_transport import WorldChartGroup
from estimators.linalg import Array
from estimators.spaces import MeanNotConvergedError

from .quaternion import qconj, qexp, qlog, qmul, skew
from .strapdown import dcm_unit as qdcm

Side = Literal["right", "left"]

#: Below this angle the Jacobian coefficients use their Taylor series (truncation < 1e-15).
_SERIES = 0.1


# --------------------------------------------------------------------------- SO(3) kit

def _T(A: Array) -> Array:
    """Batched transpose of matrices (..., i, j)."""
    return np.swapaxes(A, -1, -2)


def _qleft(a: Array) -> Array:
    """The (4, 4) matrix of left multiplication by one quaternion: ``a ⊗ b = L(a) b``."""
    w, x, y, z = a
    return np.array([[w, -x, -y, -z], [x, w, -z, y], [y, z, w, -x], [z, -y, x, w]])


def jl_matrix(phi: Array, inverse: bool = False) -> Array:
    r""":math:`J_l(φ) = I + a[φ]_\times + b[φ]_\times^2` or
    :math:`J_l(φ)^{-1} = I - \tfrac12[φ]_\times + c[φ]_\times^2` as matrices (..., 3, 3),
    with :math:`a = (1 - \cos t)/t^2`, :math:`b = (t - \sin t)/t^3`,
    :math:`c = (1 - \tfrac t2\cot\tfrac t2)/t^2` and :math:`[φ]_\times^2 = φφ^\top - t^2 I`.
    Below :data:`_SERIES` the coefficients are Taylor series (they cancel there); ``c`` is
    finite up to and at :math:`t = π`."""
    phi = np.asarray(phi, dtype=float)
    t2 = np.einsum("...i,...i->...", phi, phi)
    if inverse:
        a: Array | float = -0.5
        b = _series_or(t2, (1 / 12, 1 / 720, 1 / 30240, 1 / 1209600),
                       lambda t: (1.0 - 0.5 * t / np.tan(0.5 * t)) / (t * t))
    else:
        a = _series_or(t2, (0.5, -1 / 24, 1 / 720, -1 / 40320),
                       lambda t: (1.0 - np.cos(t)) / (t * t))
        b = _series_or(t2, (1 / 6, -1 / 120, 1 / 5040, -1 / 362880),
                       lambda t: (t - np.sin(t)) / t**3)
    # J = b φφᵀ + (1 - b t²) I + a [φ]x
    J = (b[..., None, None] * phi[..., :, None]) * phi[..., None, :]
    d = 1.0 - b * t2
    ax = a * phi if inverse else a[..., None] * phi
    J[..., 0, 0] += d
    J[..., 1, 1] += d
    J[..., 2, 2] += d
    J[..., 0, 1] -= ax[..., 2]
    J[..., 1, 0] += ax[..., 2]
    J[..., 0, 2] += ax[..., 1]
    J[..., 2, 0] -= ax[..., 1]
    J[..., 1, 2] -= ax[..., 0]
    J[..., 2, 1] += ax[..., 0]
    return J


def _series_or(t2: Array, coef: tuple[float, ...], closed) -> Array:
    """``Σ coef[k] t^{2k}`` where :math:`t <` :data:`_SERIES`, else ``closed(t)``."""
    series = coef[0] + t2 * (coef[1] + t2 * (coef[2] + t2 * coef[3]))
    small = t2 < _SERIES * _SERIES
    if small.all():
        return series
    ts = np.where(small, 1.0, np.sqrt(t2))
    return np.where(small, series, closed(ts))


def jl_apply(phi: Array, u: Array, inverse: bool = False) -> Array:
    r""":math:`J_l(φ) u` (or :math:`J_l(φ)^{-1} u`) for rotation vectors ``phi`` (..., 3) and
    vectors ``u`` (..., k, 3), batched over ``...``."""
    return np.matmul(u, _T(jl_matrix(phi, inverse)))


def _rotate_shared(u: Array, R: Array) -> Array:
    """``u @ R_iᵀ`` for one set of vectors ``u`` (k, 3) and rotations ``R`` (m, 3, 3):
    (m, k, 3), as one matrix product (``np.matmul`` of small stacks is several times
    slower)."""
    m = R.shape[0]
    return (R.reshape(3 * m, 3) @ u.T).reshape(m, 3, -1).transpose(0, 2, 1)


def _sum_products(A: Array, B: Array) -> Array:
    r""":math:`\sum_i A_i B_i` for stacks (m, a, 3) and (m, 3, b), as one matrix product."""
    m, a, _ = A.shape
    return A.transpose(1, 0, 2).reshape(a, 3 * m) @ B.reshape(3 * m, -1)

# --------------------------------------------------------------------------- the space

@lru_cache(maxsize=256)
def _vector_index(n_landmarks: int, start: int) -> Array:
    """(2 + n, 3) columns of ``p, v, m_1, ...`` with the landmarks from ``start``."""
    idx = np.concatenate([np.arange(6), start + np.arange(3 * n_landmarks)]).reshape(-1, 3)
    idx.setflags(write=False)
    return idx


@dataclass(frozen=True)
class ExtendedPoseGroup(WorldChartGroup):
    """:math:`SE_{2+n}(3)` × biases (module docstring); a :class:`~estimators.spaces.Space`
    on ``[p, v, q, b, m_1, ..., m_n]`` with ``n_landmarks`` 3-D landmarks and ``n_bias``
    bias coordinates.  Vectorised over points (rows) and the :math:`2 + n` vectors."""

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

    # index bookkeeping: the vectors (p, v, m_1, ...) as (k, 3) column blocks
    @property
    def _amb(self) -> Array:
        return _vector_index(self.n_landmarks, 10 + self.n_bias)

    @property
    def _tan(self) -> Array:
        return _vector_index(self.n_landmarks, 9 + self.n_bias)

    @property
    def _bias(self) -> tuple[slice, slice]:
        return slice(10, 10 + self.n_bias), slice(9, 9 + self.n_bias)

    def _assemble(self, q: Array, vecs: Array, b: Array) -> Array:
        out = np.empty(q.shape[:-1] + (self.ambient_dim,))
        out[..., 6:10] = q
        out[..., self._amb] = vecs
        out[..., self._bias[0]] = b
        return out

    def exp(self, xi: Array) -> Array:
        """Ambient coordinates of :math:`\\exp(ξ)` (biases: ``δb``)."""
        xi = np.asarray(xi, dtype=float)
        th = xi[..., 6:9]
        return self._assemble(qexp(th), jl_apply(th, xi[..., self._tan]), xi[..., self._bias[1]])

    def log(self, x: Array) -> Array:
        """Inverse of :meth:`exp` (rotation angle in ``[0, π]``)."""
        x = np.asarray(x, dtype=float)
        th = qlog(x[..., 6:10])
        out = np.empty(x.shape[:-1] + (self.dim,))
        out[..., 6:9] = th
        out[..., self._tan] = jl_apply(th, x[..., self._amb], inverse=True)
        out[..., self._bias[1]] = x[..., self._bias[0]]
        return out

    def retract(self, x: Array, delta: Array) -> Array:
        x, d = np.asarray(x, dtype=float), np.asarray(delta, dtype=float)
        if self.side == "right" and x.ndim == 1 and d.ndim == 2:
            turn = np.any(d[:, 6:9] != 0.0, axis=1)
            if not turn.all():   # Exp(0) = I, J_l(0) = I: Exp(ξ)X translates every vector
                out = np.repeat(x[None], d.shape[0], axis=0)
                out[:, self._amb.ravel()] += d[:, self._tan.ravel()]
                out[:, self._bias[0]] += d[:, self._bias[1]]
                out[turn] = self._retract(x, d[turn])
                return out
        return self._retract(x, d)

    def _retract(self, x: Array, d: Array) -> Array:
        th = d[..., 6:9]
        dq = qexp(th)
        q, u = x[..., 6:10], x[..., self._amb]
        ju = jl_apply(th, d[..., self._tan])
        if self.side == "right":   # exp(ξ) X
            qn = qmul(dq, q)
            R = qdcm(dq)
            new = (_rotate_shared(u, R) if u.ndim == 2 and R.ndim == 3
                   else np.matmul(u, _T(R))) + ju
        else:                      # X exp(ξ)
            qn = qmul(q, dq)
            new = u + np.matmul(ju, _T(qdcm(q)))
        qn = qn / np.linalg.norm(qn, axis=-1, keepdims=True)
        return self._assemble(qn, new, x[..., self._bias[0]] + d[..., self._bias[1]])

    def local(self, x: Array, y: Array) -> Array:
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        qx, qy = x[..., 6:10], y[..., 6:10]
        ux, uy = x[..., self._amb], y[..., self._amb]
        if self.side == "right":   # log(Y X⁻¹)
            dq = qmul(qy, qconj(qx))
            R = qdcm(dq)
            du = uy - (_rotate_shared(ux, R) if ux.ndim == 2 and R.ndim == 3
                       else np.matmul(ux, _T(R)))
        else:                      # log(X⁻¹ Y)
            dq = qmul(qconj(qx), qy)
            du = np.matmul(uy - ux, qdcm(qx))
        th = qlog(dq)
        shape = np.broadcast_shapes(x.shape[:-1], y.shape[:-1])
        out = np.empty(shape + (self.dim,))
        out[..., 6:9] = th
        out[..., self._tan] = jl_apply(th, du, inverse=True)
        out[..., self._bias[1]] = y[..., self._bias[0]] - x[..., self._bias[0]]
        return out

    def _attitude_mean(self, qs: Array, w: Array) -> Array:
        """Weighted Karcher mean of unit quaternions (m, 4) by fixed-point iteration from
        the sign-aligned chordal mean; the same point for either side (bi-invariant)."""
        ref = qs[int(np.argmax(w))]
        q = w @ (qs * np.where(qs @ ref < 0.0, -1.0, 1.0)[:, None])
        q = q / np.sqrt(q @ q)
        floor = 8.0 * np.finfo(float).eps * float(np.abs(w).sum())
        prev = step_n = np.inf
        for _ in range(self.max_iter):
            step = w @ qlog(qs @ _qleft(qconj(q)).T)         # Σ wᵢ Log(q̄* ⊗ qᵢ)
            q = _qleft(q) @ qexp(step)
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

        one 3 × 3 solve for all :math:`2 + n` vectors (right: since
        :math:`J_l(φ)^{-1}\mathrm{Exp}(φ) = J_l(φ)^{-1} + [φ]_\times` and
        :math:`\sum_i w_i φ_i = 0` at :math:`\bar R`, the matrix equals
        :math:`\sum_i w_i J_i` up to the attitude iteration's tolerance).  A singular
        system (a cloud spread over ~π) raises :class:`MeanNotConvergedError`.
        """
        pts = np.asarray(points, dtype=float)
        w = np.asarray(weights, dtype=float)
        qbar = self._attitude_mean(pts[:, 6:10], w)
        u = pts[:, self._amb]                                    # (m, k, 3)
        Rbar = qdcm(qbar)
        if self.side == "right":
            dq = qmul(pts[:, 6:10], qconj(qbar))
            J = jl_matrix(qlog(dq), inverse=True) * w[:, None, None]
            A = _sum_products(J, qdcm(dq))
            rhs = _sum_products(u, _T(J))
        else:
            dq = qmul(qconj(qbar), pts[:, 6:10])
            J = jl_matrix(qlog(dq), inverse=True) * w[:, None, None]
            A = J.sum(axis=0)
            rhs = np.matmul(u @ Rbar, _T(J)).sum(axis=0)
        if not (np.all(np.isfinite(A)) and np.linalg.cond(A) < 1e8):
            raise MeanNotConvergedError("group mean undefined (singular barycentre system)")
        ubar = np.linalg.solve(A, rhs.T).T
        if self.side == "left":
            ubar = ubar @ Rbar.T
        return self._assemble(qbar, ubar, w @ pts[:, self._bias[0]])

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

    def _apply(self, x: Array, A: Array, inverse: bool) -> Array:
        x, A = np.asarray(x, dtype=float), np.asarray(A, dtype=float)
        R, tan = qdcm(x[6:10]), self._tan
        out = A.copy()
        if self.side == "right":
            S = skew(x[self._amb])                                 # (k, 3, 3)
            th = R @ A[6:9] if inverse else R.T @ A[6:9]
            rot = th if inverse else A[6:9]                        # ξ_θ either way
            out[6:9] = th
            corr = np.einsum("kij,j...->ki...", S, rot)
            out[tan] = A[tan] + corr if inverse else A[tan] - corr
            return out
        out[tan] = np.einsum("ji,kj...->ki...", R, A[tan]) if inverse else \
            np.einsum("ij,kj...->ki...", R, A[tan])
        return out

    def right_world(self, x: Array, B: Array) -> Array:
        r""":math:`B M` for ``B`` (r, d) with tangent columns: a Jacobian in the standard
        chart carried to the group's error (right: column block θ becomes
        :math:`B_θ R^\top - \sum_u B_u [u]_\times`)."""
        x, B = np.asarray(x, dtype=float), np.asarray(B, dtype=float)
        R, tan = qdcm(x[6:10]), self._tan
        out = B.copy()
        if self.side == "right":
            S = skew(x[self._amb])
            out[:, 6:9] = B[:, 6:9] @ R.T - np.einsum("rki,kij->rj", B[:, tan], S)
            return out
        out[:, tan] = B[:, tan] @ R
        return out


    @property
    def transport_lead(self) -> int:
        r"""Right error: :math:`T` rotates the attitude rows by :math:`R_{new}^\top R_{old}`
        and adds multiples of them to the p, v and landmark rows, so in a lower factor it
        touches columns 0-8 alone.  Implemented for the right error only."""
        if self.side != "right":
            raise ValueError("the covariance transport is implemented for the right error")
        return 9


def chain_jacobians(space_in: ExtendedPoseGroup, space_out: ExtendedPoseGroup, x: Array,
                    y: Array, F: Array, G: Array | None = None
                    ) -> tuple[Array, Array | None]:
    r"""A transition's standard-chart Jacobians in the group's error by the chain rule:
    :math:`F_ξ = M(y)^{-1} F M(x)`, :math:`G_ξ = M(y)^{-1} G` (``x`` the input mean,
    ``y = f(x)``)."""
    Fx = space_out.from_world(y, space_in.right_world(x, F))
    return Fx, None if G is None else space_out.from_world(y, G)
