r"""Spaces: where a state or a measurement lives, and how to move on it.

A space maps between *ambient* coordinates (what a model computes, e.g. a unit
quaternion, 4 numbers) and *tangent* coordinates (the error a covariance describes,
e.g. a 3-vector rotation).  Filters never add or subtract ambient coordinates
directly; they use the two operators

.. math::

    x \boxplus \delta = \mathrm{retract}(x, \delta), \qquad
    y \boxminus x = \mathrm{local}(x, y),

with :math:`\mathrm{local}(x, \mathrm{retract}(x, \delta)) = \delta` near zero.
Sigma-point means are computed in local coordinates (:meth:`Space.mean`), never by
averaging ambient coordinates.

Points are rows: every operator takes arrays of shape ``(..., dim)`` and
broadcasts over the leading axes.  Spaces are immutable values.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

_TWO_PI = 2.0 * math.pi


@runtime_checkable
class Space(Protocol):
    """What a filter needs to know about a state or measurement space.

    Attributes
    ----------
    ambient_dim : int
        Length of a point's coordinate vector.
    dim : int
        Tangent dimension (the size of a covariance on this space).
    """

    ambient_dim: int
    dim: int

    def retract(self, x: Array, delta: Array) -> Array:
        """``x ⊞ δ``: ``x`` shape ``(..., ambient_dim)``, ``δ`` shape ``(..., dim)``."""
        ...

    def local(self, x: Array, y: Array) -> Array:
        """``y ⊟ x`` in the tangent space at ``x``: shape ``(..., dim)``."""
        ...

    def mean(self, points: Array, weights: Array) -> Array:
        """Weighted mean of ``points`` ``(..., m, ambient_dim)`` with ``weights`` ``(m,)``
        (one mean per leading index: a batch of clouds).

        Weights sum to one but may be negative (unscented and central-difference rules).
        """
        ...


class MeanNotConvergedError(ArithmeticError):
    """A group space's sigma-point mean is undefined (a cloud spread over about a half turn)
    or its iteration did not converge."""


def wrap_angle(a: Array | float) -> Array | float:
    """Wrap angles to ``[-π, π)`` (a float ``%`` that rounds up to π is mapped to -π).

    The one angle-wrapping function of the project.  A Python ``float`` in gives a
    ``float`` out by scalar arithmetic (the same IEEE operations, for simulator loops).
    """
    if isinstance(a, float):
        w = (a + math.pi) % _TWO_PI - math.pi
        return w - _TWO_PI if w >= math.pi else w
    out = np.asarray(a, dtype=float) + np.pi
    if out.ndim == 0:
        out = out % _TWO_PI - np.pi
        return np.where(out >= np.pi, out - _TWO_PI, out)
    np.remainder(out, _TWO_PI, out=out)  # in place on the fresh sum: the same operations
    out -= np.pi
    high = out >= np.pi
    if high.any():
        out[high] -= _TWO_PI
    return out


class _Flat:
    """Spaces whose points are ``n`` plain numbers: ambient and tangent dims are ``n``."""

    n: int

    @property
    def ambient_dim(self) -> int:
        return self.n

    @property
    def dim(self) -> int:
        return self.n


@dataclass(frozen=True)
class Euclidean(_Flat):
    """:math:`\\mathbb{R}^n` with ordinary addition."""

    n: int

    def retract(self, x: Array, delta: Array) -> Array:
        return x + delta

    def local(self, x: Array, y: Array) -> Array:
        return y - x

    def mean(self, points: Array, weights: Array) -> Array:
        return weights @ points


@dataclass(frozen=True)
class Angle(_Flat):
    """``n`` independent angles (radians), each wrapped to ``[-π, π)``.

    The tangent chart is a translation, so the weighted mean in the chart at any
    point of a cloud narrower than π is exact in one pass.
    """

    n: int = 1

    def retract(self, x: Array, delta: Array) -> Array:
        return wrap_angle(x + delta)

    def local(self, x: Array, y: Array) -> Array:
        return wrap_angle(y - x)

    def mean(self, points: Array, weights: Array) -> Array:
        ref = points[..., 0, :]
        return wrap_angle(ref + weights @ wrap_angle(points - ref[..., None, :]))


@dataclass(frozen=True)
class Product:
    """Cartesian product of spaces; coordinates are concatenated in order."""

    parts: tuple[Space, ...]
    _amb: tuple[slice, ...] = field(init=False, repr=False, compare=False)
    _tan: tuple[slice, ...] = field(init=False, repr=False, compare=False)

    def __init__(self, parts: Sequence[Space]):
        flat: list[Space] = []
        for p in parts:  # flatten nested products so slices stay simple
            flat.extend(p.parts if isinstance(p, Product) else [p])
        object.__setattr__(self, "parts", tuple(flat))
        amb, tan, a, t = [], [], 0, 0
        for p in flat:
            amb.append(slice(a, a + p.ambient_dim))
            tan.append(slice(t, t + p.dim))
            a += p.ambient_dim
            t += p.dim
        object.__setattr__(self, "_amb", tuple(amb))
        object.__setattr__(self, "_tan", tuple(tan))

    @property
    def ambient_dim(self) -> int:
        return sum(p.ambient_dim for p in self.parts)

    @property
    def dim(self) -> int:
        return sum(p.dim for p in self.parts)

    def retract(self, x: Array, delta: Array) -> Array:
        return np.concatenate(
            [p.retract(x[..., a], delta[..., t])
             for p, a, t in zip(self.parts, self._amb, self._tan)], axis=-1)

    def local(self, x: Array, y: Array) -> Array:
        return np.concatenate(
            [p.local(x[..., a], y[..., a]) for p, a in zip(self.parts, self._amb)], axis=-1)

    def mean(self, points: Array, weights: Array) -> Array:
        return np.concatenate(
            [p.mean(points[..., a], weights) for p, a in zip(self.parts, self._amb)], axis=-1)


@dataclass(frozen=True)
class Wrapped(_Flat):
    """:math:`\\mathbb{R}^n` whose coordinates listed in ``angles`` are wrapped angles.

    A flat alternative to a long :class:`Product` of :class:`Euclidean` and
    :class:`Angle` parts (e.g. a stack of range-bearing observations).
    """

    n: int
    angles: tuple[int, ...]

    def _wrap(self, v: Array) -> Array:
        out = np.array(v, dtype=float, copy=True)
        if len(self.angles) == 1:
            i = self.angles[0]
            out[..., i] = wrap_angle(out[..., i])
        elif self.angles:  # all at once (elementwise: the same numbers as one by one)
            idx = list(self.angles)
            out[..., idx] = wrap_angle(out[..., idx])
        return out

    def retract(self, x: Array, delta: Array) -> Array:
        return self._wrap(x + delta)

    def local(self, x: Array, y: Array) -> Array:
        return self._wrap(y - x)

    def mean(self, points: Array, weights: Array) -> Array:
        ref = points[..., 0, :]
        return self._wrap(ref + weights @ self._wrap(points - ref[..., None, :]))
