r"""The planar SLAM group :math:`SE_{1+n}(2)` as a state space: invariant error for the
existing filters (Barrau & Bonnabel 2015; its sigma-point use: Brossard et al. 2020).

A planar SLAM state - heading :math:`φ`, position :math:`p` and landmarks
:math:`l_1 \dots l_n` - is the group element

.. math::

    X = \begin{bmatrix} R(φ) & p & l_1 & \cdots & l_n \\ 0 & & I_{1+n} & \end{bmatrix}
    \in SE_{1+n}(2).

Ambient coordinates are the usual ``[x, y, φ, l_1x, l_1y, ...]`` (so every planar model,
simulator and score is unchanged); tangent coordinates are the Lie algebra element in the
same order, :math:`ξ = [ξ_x, ξ_y, ξ_φ, ξ_{1x}, ξ_{1y}, \dots]`.  With planar vectors as
complex numbers, :math:`\exp(ξ) = (ξ_φ,\ V(ξ_φ) ξ_p,\ V(ξ_φ) ξ_{l_i})`,
:math:`V(θ) = (e^{iθ} - 1)/(iθ)`, :math:`V(θ)^{-1} = \tfrac{θ}{2}(\cot\tfrac{θ}{2} - i)`
(closed form through sinc, exact at 0; :math:`θ \in [-π, π)`).

``side = "right"`` (right-invariant error, the default):
:math:`x \boxplus ξ = \exp(ξ)\,X`, :math:`y \boxminus x = \log(Y X^{-1})`; a common
rotation of the whole map about the origin is :math:`ξ = (0, 0, δφ, 0, \dots)` and a
common translation :math:`ξ = (t, 0, t, \dots, t)` at every estimate - the unobservable
directions no longer depend on where the filter linearises.  ``side = "left"``:
:math:`x \boxplus ξ = X\exp(ξ)`, :math:`y \boxminus x = \log(X^{-1} Y)` (body-frame error).

A filter uses these spaces instead of :class:`~estimators.spaces.Wrapped`; nothing in the
filters changes (the invariant SRCKF is the SRCKF on this space).  The sigma-point mean
(:meth:`SlamGroup.mean`) is the group barycentre, :math:`\sum_i w_i (x_i \boxminus \bar x) = 0`,
in closed form.  :meth:`SlamGroup.to_world` applies
:math:`M = \partial(\text{standard error})/\partial ξ`, the first-order map to the world-frame
``(x, y, φ, l)`` error used for scoring and for analytic Jacobians given in the standard
chart (:func:`invariant_jacobians`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from .group_transport import WorldChartGroup
from .linalg import Array, matvec
from .spaces import MeanNotConvergedError, wrap_angle

Side = Literal["right", "left"]


def _half(theta: Array) -> tuple[Array, Array, Array]:
    r"""``(θ, q, sinc θ/2)`` with :math:`q = e^{iθ/2}` and :math:`\mathrm{sinc}\,0 = 1`: one
    complex exponential gives every closed form, :math:`e^{iθ} = q^2`,
    :math:`V = \mathrm{sinc}\tfrac{θ}{2}\,q`, :math:`V^{-1} = \bar q/\mathrm{sinc}\tfrac{θ}{2}`."""
    t = np.asarray(theta, dtype=float)
    h = 0.5 * t
    q = np.exp(1j * h)
    sc = np.divide(q.imag, h, out=np.ones_like(h), where=h != 0.0)
    return t, q, sc


def so2_v(theta: Array) -> Array:
    r""":math:`V(θ) = (e^{iθ} - 1)/(iθ) = \mathrm{sinc}\tfrac{θ}{2}\,e^{iθ/2}`
    (no branch at 0)."""
    _, q, sc = _half(theta)
    return sc * q


def so2_v_inv(theta: Array) -> Array:
    r""":math:`V(θ)^{-1} = \tfrac{θ}{2}\cot\tfrac{θ}{2} - i\tfrac{θ}{2}
    = e^{-iθ/2} / \mathrm{sinc}\tfrac{θ}{2}` for :math:`|θ| \le π`."""
    _, q, sc = _half(theta)
    return q.conj() / sc


def _split(x: Array) -> tuple[Array, Array]:
    """Heading (...,) and the positions ``[p, l_1, ..., l_n]`` as complex (..., 1 + n)."""
    x = np.asarray(x, dtype=float)
    xy = np.concatenate((x[..., 0:2], x[..., 3:]), axis=-1)
    return x[..., 2], xy.view(np.complex128)


def _join(phi: Array, pts: Array) -> Array:
    """Inverse of :func:`_split`."""
    f = np.ascontiguousarray(pts, dtype=np.complex128).view(np.float64)
    out = np.empty(f.shape[:-1] + (1 + f.shape[-1],))
    out[..., 0:2] = f[..., 0:2]
    out[..., 3:] = f[..., 2:]
    out[..., 2] = phi
    return out


def _col(a: Array) -> Array:
    """``a[..., None]``: a per-point factor against the (..., 1 + n) positions."""
    return np.asarray(a)[..., None]


def exp_map(xi: Array) -> Array:
    """Group exponential: ambient coordinates of :math:`\\exp(ξ)` (identity = zeros)."""
    th, u = _split(xi)
    t, q, sc = _half(th)
    return _join(wrap_angle(t), _col(sc * q) * u)


def log_map(x: Array) -> Array:
    """Group logarithm (heading wrapped to ``[-π, π)``): inverse of :func:`exp_map`."""
    th, p = _split(x)
    t, q, sc = _half(wrap_angle(th))
    return _join(t, _col(q.conj() / sc) * p)


@dataclass(frozen=True)
class SlamGroup(WorldChartGroup):
    """:math:`SE_{1+n}(2)` with ``n_landmarks`` landmarks and right- or left-invariant
    error (module docstring); a :class:`~estimators.spaces.Space`.

    Every operation is vectorised over points (rows) and landmarks (complex columns); each
    heading's trigonometry is evaluated once (:func:`_half`).  Every operation also takes
    leading batch axes (a batch of beliefs, :mod:`estimators.batch`): ``x`` (..., d),
    matrices (..., d, m), point clouds (..., m, d); each member's result is the one-belief
    call's to round-off."""

    n_landmarks: int
    side: Side = "right"

    def __post_init__(self) -> None:
        if self.side not in ("right", "left"):
            raise ValueError(f"side must be 'right' or 'left', not {self.side!r}")

    @property
    def ambient_dim(self) -> int:
        return 3 + 2 * self.n_landmarks

    @property
    def dim(self) -> int:
        return 3 + 2 * self.n_landmarks

    def retract(self, x: Array, delta: Array) -> Array:
        phi, pts = _split(x)
        th, u = _split(delta)
        t, q, sc = _half(th)
        v = sc * q if self.side == "right" else np.exp(1j * phi) * (sc * q)
        # right, exp(ξ) X: translate and rotate every point; left, X exp(ξ): translate in
        # the body frame.  u is a fresh copy: in place unless x broadcasts ξ to more rows
        own = u if np.shape(t) == np.broadcast_shapes(np.shape(t), np.shape(phi)) else None
        new = np.multiply(u, _col(v), out=own)
        new = np.add(new, _col(q * q) * pts if self.side == "right" else pts, out=own)
        return _join(wrap_angle(phi + t), new)

    def local(self, x: Array, y: Array) -> Array:
        phx, px = _split(x)
        phy, py = _split(y)
        t, q, sc = _half(wrap_angle(phy - phx))
        vinv = q.conj() / sc
        if self.side == "right":   # log(Y X⁻¹)
            d = _col(q * q) * px
            np.subtract(py, d, out=d)
            d *= _col(vinv)
        else:                      # log(X⁻¹ Y)
            d = py - px
            d *= _col(vinv * np.exp(-1j * phx))
        return _join(t, d)

    def mean(self, points: Array, weights: Array) -> Array:
        r"""The group barycentre: :math:`\sum_i w_i (x_i \boxminus \bar x) = 0`, in closed
        form.  The heading :math:`\bar φ` is the chart mean (exact for a cloud narrower
        than π, as :class:`~estimators.spaces.Angle`); with :math:`Δ_i = φ_i - \bar φ` and
        :math:`V_i = V(Δ_i)` the translation part is linear in :math:`\bar p`:

        .. math::

            \text{right: } \bar p = \frac{\sum_i w_i V_i^{-1} p_i}
            {\sum_i w_i V_i^{-1} e^{iΔ_i}},\qquad
            \text{left: } \bar p = \frac{\sum_i w_i V_i^{-1} p_i}{\sum_i w_i V_i^{-1}}

        (complex numbers; the same for every landmark; :math:`V^{-1}(Δ) e^{iΔ}
        = e^{iΔ/2}/\mathrm{sinc}\tfrac{Δ}{2} = \overline{V^{-1}(Δ)}`).  A vanishing
        denominator (a cloud spread over ~2π) raises :class:`MeanNotConvergedError`.
        A batch of clouds (..., m, d) gives (..., d); any member's failure raises.
        """
        phi, pts = _split(points)
        if phi.ndim == 1:
            ref = phi[0]
            mphi = wrap_angle(ref + weights @ wrap_angle(phi - ref))
        else:
            ref = phi[..., :1]
            mphi = wrap_angle(ref[..., 0] + matvec(wrap_angle(phi - ref), weights))
        _, q, sc = _half(wrap_angle(phi - _col(mphi)))
        vinv = weights * q.conj() / sc
        den = np.sum(vinv, axis=-1)
        if self.side == "right":   # w V⁻¹ e^{iΔ} = w q / sinc: the conjugate of w V⁻¹
            den = den.conjugate()
        ok = np.isfinite(den) & (np.abs(den) > 1e-9)
        if not np.all(ok):
            bad = complex(np.ravel(den)[~np.ravel(ok)][0])
            raise MeanNotConvergedError(f"group mean undefined (weight sum {bad:.3e})")
        if phi.ndim == 1:
            return _join(mphi, (vinv @ pts) / den)
        return _join(mphi, (vinv[..., None, :] @ pts)[..., 0, :] / _col(den))

    def to_world(self, x: Array, A: Array) -> Array:
        r""":math:`M A` with :math:`M = \partial\,(\mathrm{std}(x \boxplus ξ) \boxminus_{std}
        x)/\partial ξ|_0` at one point ``x``: the world-frame ``(x, y, φ, l)`` rows of a
        tangent-row matrix ``A`` (d, m) - e.g. a covariance factor, :math:`P_w = M P M^\top`.

        Right: :math:`M = I + a e_φ^\top`, :math:`a = (Jp, 0, Jl_1, \dots)`,
        :math:`J = [[0, -1], [1, 0]]`; left: :math:`M = \mathrm{blkdiag}(R, 1, R, \dots)`.
        Applied by blocks (a rank-one update or 2×2 rotations), never as a (d, d) matrix.
        """
        return self._apply(x, A, inverse=False)

    def from_world(self, x: Array, A: Array) -> Array:
        """:math:`M^{-1} A` (see :meth:`to_world`)."""
        return self._apply(x, A, inverse=True)

    def _apply(self, x: Array, A: Array, inverse: bool) -> Array:
        A = np.asarray(A, dtype=float)
        x = np.asarray(x, dtype=float)
        if self.side == "right":   # rows a_x, a_y += ∓ (J q) A_φ for q = p, l_i
            sign = -1.0 if inverse else 1.0
            c = np.empty(x.shape)   # ±a: one rank-one update of every row at once
            c[..., 0], c[..., 1], c[..., 2] = -sign * x[..., 1], sign * x[..., 0], 0.0
            c[..., 3::2] = -sign * x[..., 4::2]
            c[..., 4::2] = sign * x[..., 3::2]
            out = c[..., :, None] * A[..., 2:3, :]
            out += A
            out[..., 2, :] = A[..., 2, :]   # the heading row is unchanged (exactly, even -0.0)
            return out
        phi = -x[..., 2] if inverse else x[..., 2]
        c, s = np.cos(phi)[..., None, None], np.sin(phi)[..., None, None]
        out = np.empty(np.broadcast_shapes(x.shape[:-1] + (1, 1), A.shape))
        out[..., 2, :] = A[..., 2, :]
        for ix, iy in ((slice(0, 1), slice(1, 2)), (slice(3, None, 2), slice(4, None, 2))):
            out[..., ix, :] = c * A[..., ix, :] - s * A[..., iy, :]
            out[..., iy, :] = s * A[..., ix, :] + c * A[..., iy, :]
        return out

    def right_world(self, x: Array, B: Array) -> Array:
        """:math:`B M` for a matrix ``B`` (k, d) with tangent columns (see :meth:`to_world`):
        a Jacobian in the standard chart turned into one in the group's error."""
        B, x = np.asarray(B, dtype=float), np.asarray(x, dtype=float)
        if self.side == "right":   # column φ += B a, a = (J p, 0, J l_1, ...)
            out = np.array(np.broadcast_to(B, np.broadcast_shapes(B.shape, x.shape[:-1]
                                                                  + (1, 1))))
            out[..., :, 2] += (B[..., :, 1] * x[..., None, 0] - B[..., :, 0] * x[..., None, 1]
                               + matvec(B[..., :, 4::2], x[..., 3::2])
                               - matvec(B[..., :, 3::2], x[..., 4::2]))
            return out
        # M = blkdiag(R, 1, R, ...): rotate column pairs
        c, s = np.cos(x[..., 2])[..., None, None], np.sin(x[..., 2])[..., None, None]
        out = np.empty(np.broadcast_shapes(x.shape[:-1] + (1, 1), B.shape))
        out[..., :, 2] = B[..., :, 2]
        for ix, iy in ((slice(0, 1), slice(1, 2)), (slice(3, None, 2), slice(4, None, 2))):
            out[..., :, ix] = c * B[..., :, ix] + s * B[..., :, iy]
            out[..., :, iy] = c * B[..., :, iy] - s * B[..., :, ix]
        return out

    def tail_gain(self, x: Array, m: Array, y: Array) -> Array:
        r"""A declaration for :mod:`estimators.structured`'s group prediction: the complex
        factor :math:`a` (...,) with :math:`y' \boxminus m = y \boxminus m + a\,ξ_{l_i}` for
        every landmark (complex coordinates; the vehicle and heading rows unchanged), where
        ξ is zero on rows 0-2 and :math:`y'` is ``y`` with its landmarks moved as
        :math:`x \boxplus ξ` moves those of ``x`` (a motion that moves the pose only).
        Right: :math:`x \boxplus ξ` adds :math:`ξ_l`, so :math:`a = V^{-1}(φ_y - φ_m)`;
        left: it adds :math:`e^{iφ_x} ξ_l`, so :math:`a = V^{-1}(φ_y - φ_m)\,e^{i(φ_x - φ_m)}`.
        """
        phx, phm = np.asarray(x)[..., 2], np.asarray(m)[..., 2]
        _, q, sc = _half(wrap_angle(np.asarray(y)[..., 2] - phm))
        vinv = q.conj() / sc
        return vinv if self.side == "right" else vinv * np.exp(1j * (phx - phm))

    @property
    def prefix_rows(self) -> int:
        r"""A declaration for :mod:`estimators.structured`: for every ``r >= 3`` the first
        ``r`` ambient coordinates of :math:`x \boxplus ξ` depend only on the first ``r``
        tangent rows of ξ (a landmark moves with its own ξ and the heading's, row 2; the
        position with ξ_x, ξ_y, ξ_φ), and ξ zero there leaves them exactly as they are."""
        return 3

    @property
    def transport_lead(self) -> int | None:
        r"""Right error: :math:`T = I + Δa\,e_φ^\top` adds multiples of the heading row to
        the position rows (in a lower factor, columns 0-2 only); left error (``None``):
        :math:`T = \mathrm{blkdiag}(R(Δφ), 1, R(Δφ), \dots)` rotates every position's pair
        of rows, each pair's 2×2 block then made triangular again (:math:`O(d^2)`)."""
        return 3 if self.side == "right" else None

    def lower_factor(self, S: Array) -> Array:
        """``S`` with each position pair's 2×2 diagonal block made lower triangular."""
        return _lower_pairs(S)


def invariant_jacobians(space_in: SlamGroup, space_out: SlamGroup, x: Array, y: Array,
                        F: Array, G: Array | None = None) -> tuple[Array, Array | None]:
    r"""A transition's Jacobians in the standard chart, carried to the group's error by the
    chain rule: :math:`F_ξ = M(y)^{-1} F M(x)`, :math:`G_ξ = M(y)^{-1} G` (``x`` the input
    mean, ``y = f(x)``).  For a group-affine motion (the car model) the right-invariant
    :math:`F_ξ` is the identity (Barrau & Bonnabel 2015)."""
    FM = space_in.right_world(x, F)
    Fx = space_out.from_world(y, FM)
    Gx = None if G is None else space_out.from_world(y, G)
    return Fx, Gx


def invariant_h(space: SlamGroup, x: Array, H: Array) -> Array:
    r"""A measurement Jacobian in the standard chart carried to the group's error:
    :math:`H_ξ = H M(x)`."""
    return space.right_world(x, H)


def _lower_pairs(S: Array) -> Array:
    """Clear the above-diagonal entry of each position pair's 2×2 diagonal block - columns
    (0, 1), (3, 4), (5, 6), ... - by one Givens rotation of the pair's columns (all pairs at
    once), keeping the diagonal non-negative (a batch (..., d, d): member by member)."""
    a = np.r_[0, 3:S.shape[-1]:2]
    b = a + 1
    saa, sab = S[..., a, a], S[..., a, b]
    r = np.hypot(saa, sab)
    c = np.divide(saa, r, out=np.ones_like(r), where=r > 0.0)[..., None, :]
    s = np.divide(sab, r, out=np.zeros_like(r), where=r > 0.0)[..., None, :]
    ca, cb = S[..., :, a], S[..., :, b]
    S[..., :, a] = ca * c + cb * s
    S[..., :, b] = cb * c - ca * s
    S[..., a, b] = 0.0
    neg = S[..., b, b] < 0.0
    if neg.any():
        S[..., :, b] *= np.where(neg, -1.0, 1.0)[..., None, :]
    return S
