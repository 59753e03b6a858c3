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
from functools import lru_cache
from typing import Literal

import numpy as np

from .linalg import Array
from .spaces import wrap_angle

Side = Literal["right", "left"]



class MeanNotConvergedError(ArithmeticError):
    """The group barycentre is undefined (a sigma-point cloud spread over ~2π)."""


def so2_v(theta: Array) -> Array:
    r""":math:`V(θ) = (e^{iθ} - 1)/(iθ) = \frac{\sin θ}{θ} + i\frac{1 - \cos θ}{θ}
    = \mathrm{sinc}\,θ + i\,\tfrac{θ}{2}\,\mathrm{sinc}^2\tfrac{θ}{2}` (no branch at 0)."""
    t = np.asarray(theta, dtype=float)
    h = np.sinc(t / (2.0 * np.pi))
    return np.sinc(t / np.pi) + 0.5j * t * h * h


def so2_v_inv(theta: Array) -> Array:
    r""":math:`V(θ)^{-1} = \tfrac{θ}{2}\cot\tfrac{θ}{2} - i\tfrac{θ}{2}
    = \cos\tfrac{θ}{2} / \mathrm{sinc}\tfrac{θ}{2} - i\tfrac{θ}{2}` for :math:`|θ| \le π`."""
    t = np.asarray(theta, dtype=float)
    return np.cos(0.5 * t) / np.sinc(t / (2.0 * np.pi)) - 0.5j * t


@lru_cache(maxsize=64)
def _pos_index(ambient: int) -> Array:
    """Ambient columns of ``[p_x, p_y, l_1x, l_1y, ...]`` (everything but the heading)."""
    idx = np.r_[0, 1, 3:ambient]
    idx.setflags(write=False)
    return idx


def _split(x: Array) -> tuple[Array, Array]:
    """Heading (...,) and the positions ``[p, l_1, ..., l_n]`` as complex (..., 1 + n)."""
    x = np.asarray(x, dtype=float)
    xy = np.ascontiguousarray(x[..., _pos_index(x.shape[-1])])
    return x[..., 2], xy.view(np.complex128)


def _join(phi: Array, pts: Array) -> Array:
    """Inverse of :func:`_split`."""
    pts = np.ascontiguousarray(pts, dtype=np.complex128)
    out = np.empty(pts.shape[:-1] + (1 + 2 * pts.shape[-1],))
    out[..., _pos_index(out.shape[-1])] = pts.view(np.float64)
    out[..., 2] = phi
    return out


def exp_map(xi: Array) -> Array:
    """Group exponential: ambient coordinates of :math:`\\exp(ξ)` (identity = zeros)."""
    th, u = _split(xi)
    return _join(wrap_angle(th), so2_v(th)[..., None] * u)


def log_map(x: Array) -> Array:
    """Group logarithm (heading wrapped to ``[-π, π)``): inverse of :func:`exp_map`."""
    th, t = _split(x)
    th = wrap_angle(th)
    return _join(th, so2_v_inv(th)[..., None] * t)


@dataclass(frozen=True)
class SlamGroup:
    """:math:`SE_{1+n}(2)` with ``n_landmarks`` landmarks and right- or left-invariant
    error (module docstring); a :class:`~estimators.spaces.Space`."""

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
        v = so2_v(th)[..., None] * u
        if self.side == "right":   # exp(ξ) X: rotate every point, then translate
            new = np.exp(1j * th)[..., None] * pts + v
        else:                      # X exp(ξ): translate in the body frame
            new = pts + np.exp(1j * phi)[..., None] * v
        return _join(wrap_angle(phi + th), new)

    def local(self, x: Array, y: Array) -> Array:
        phx, px = _split(x)
        phy, py = _split(y)
        th = wrap_angle(phy - phx)
        if self.side == "right":   # log(Y X⁻¹)
            t = py - np.exp(1j * th)[..., None] * px
        else:                      # log(X⁻¹ Y)
            t = np.exp(-1j * phx)[..., None] * (py - px)
        return _join(th, so2_v_inv(th)[..., None] * t)

    def mean(self, points: Array, weights: Array) -> Array:
        r"""The group barycentre: :math:`\sum_i w_i (x_i \boxminus \bar x) = 0`, in closed
        form.  The heading :math:`\bar φ` is the chart mean (exact for a cloud narrower
        than π, as :class:`~estimators.spaces.Angle`); with :math:`Δ_i = φ_i - \bar φ` and
        :math:`V_i = V(Δ_i)` the translation part is linear in :math:`\bar p`:

        .. math::

            \text{right: } \bar p = \frac{\sum_i w_i V_i^{-1} p_i}
            {\sum_i w_i V_i^{-1} e^{iΔ_i}},\qquad
            \text{left: } \bar p = \frac{\sum_i w_i V_i^{-1} p_i}{\sum_i w_i V_i^{-1}}

        (complex numbers; the same for every landmark).  A vanishing denominator (a cloud
        spread over ~2π) raises :class:`MeanNotConvergedError`.
        """
        phi, pts = _split(points)
        ref = phi[0]
        mphi = wrap_angle(ref + weights @ wrap_angle(phi - ref))
        d = wrap_angle(phi - mphi)
        vinv = weights * so2_v_inv(d)
        den = np.sum(vinv * np.exp(1j * d)) if self.side == "right" else np.sum(vinv)
        if not (np.isfinite(den) and abs(den) > 1e-9):
            raise MeanNotConvergedError(f"group mean undefined (weight sum {den:.3e})")
        return _join(mphi, (vinv @ pts) / den)

    def to_world(self, x: Array, A: Array) -> Array:
        r""":math:`M A` with :math:`M = \partial\,(\mathrm{std}(x \boxplus ξ) \boxminus_{std}
        x)/\partial ξ|_0` at one point ``x``: the world-frame ``(x, y, φ, l)`` rows of a
        tangent-row matrix ``A`` (d, m) - e.g. a covariance factor, :math:`P_w = M P M^\top`.

        Right: :math:`M = I + a e_φ^\top`, :math:`a = (Jp, 0, Jl_1, \dots)`,
        :math:`J = [[0, -1], [1, 0]]`; left: :math:`M = \mathrm{blkdiag}(R, 1, R, \dots)`.
        """
        return self._apply(x, A, inverse=False)

    def from_world(self, x: Array, A: Array) -> Array:
        """:math:`M^{-1} A` (see :meth:`to_world`)."""
        return self._apply(x, A, inverse=True)

    def _apply(self, x: Array, A: Array, inverse: bool) -> Array:
        A = np.asarray(A, dtype=float)
        phi, pts = _split(x)
        phi_row = A[2]
        xy = np.concatenate([A[0:2], A[3:]], axis=0)          # (2 + 2n, m) position rows
        c = xy[0::2] + 1j * xy[1::2]                           # (1 + n, m) complex rows
        if self.side == "right":
            sign = -1.0 if inverse else 1.0
            c = c + sign * (1j * pts)[:, None] * phi_row[None, :]
        else:
            c = np.exp((-1j if inverse else 1j) * phi) * c
        out = np.empty_like(A)
        out[2] = phi_row
        out[0], out[1] = c[0].real, c[0].imag
        out[3::2], out[4::2] = c[1:].real, c[1:].imag
        return out

    def right_world(self, x: Array, B: Array) -> Array:
        """:math:`B M` for a matrix ``B`` (k, d) with tangent columns (see :meth:`to_world`):
        a Jacobian in the standard chart turned into one in the group's error."""
        B = np.asarray(B, dtype=float)
        if self.side == "right":
            phi, pts = _split(x)
            a = 1j * pts                                       # J p, J l_i as complex
            pos = np.concatenate([B[:, 0:2], B[:, 3:]], axis=1)
            out = B.copy()
            out[:, 2] += pos[:, 0::2] @ a.real + pos[:, 1::2] @ a.imag
            return out
        return self.from_world(x, B.T).T    # M = blkdiag(R, 1, R, ...): B M = (M^T B^T)^T


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
