"""The block layout of a joint SLAM state ``[vehicle; landmark 0; landmark 1; ...]``
that the partitioned (``local``) steps of :mod:`estimators.partitioned` work on, and the
filters that have such steps."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NoReturn

import numpy as np

from .linalg import Array
from .models import Belief, Gaussian, SqrtGaussian
from .spaces import Space

#: Filters (by :func:`~estimators.make_filter` name) with partitioned (``local``) steps.
PARTITIONED_FILTERS: tuple[str, ...] = ("ekf", "srckf", "srukf", "srcdkf")


class NoPartitionedModeError(ValueError):
    """The filter has no partitioned (``local``) steps."""


def refuse_partitioned(name: str) -> NoReturn:
    """Raise :class:`NoPartitionedModeError` for the filter called ``name``."""
    raise NoPartitionedModeError(
        f"filter {name!r} has no local mode (partitioned steps); local mode supports "
        f"{', '.join(PARTITIONED_FILTERS)}")


@dataclass(frozen=True)
class BlockLayout:
    """A joint state ``[vehicle; landmark 0; landmark 1; ...]``: the vehicle's ambient and
    tangent sizes, each landmark's, and ``space_of(k)``, the space of a state with ``k``
    landmarks (the vehicle alone is ``space_of(0)``; the block of the vehicle and ``k``
    landmarks is ``space_of(k)``).  The sizes are checked against ``space_of(0)`` and
    ``space_of(1)``; :meth:`of` reads them from there."""

    vehicle_ambient: int
    vehicle_dim: int
    landmark_ambient: int
    landmark_dim: int
    space_of: Callable[[int], Space]

    def __post_init__(self) -> None:
        s0, s1 = self.space_of(0), self.space_of(1)
        want = (s0.ambient_dim, s0.dim, s1.ambient_dim - s0.ambient_dim, s1.dim - s0.dim)
        got = (self.vehicle_ambient, self.vehicle_dim, self.landmark_ambient,
               self.landmark_dim)
        if got != want:
            raise ValueError(f"layout sizes (vehicle ambient, tangent, landmark ambient, "
                             f"tangent) {got} do not match space_of: {want}")

    @classmethod
    def of(cls, space_of: Callable[[int], Space]) -> BlockLayout:
        """The layout whose sizes are those of ``space_of(0)`` and ``space_of(1)``."""
        s0, s1 = space_of(0), space_of(1)
        return cls(s0.ambient_dim, s0.dim, s1.ambient_dim - s0.ambient_dim, s1.dim - s0.dim,
                   space_of)

    def rows(self, slots: Array) -> Array:
        """Tangent rows of the vehicle followed by the landmarks in ``slots`` (in order)."""
        return _block_index(self.vehicle_dim, self.landmark_dim, slots)

    def cols(self, slots: Array) -> Array:
        """Ambient columns of the vehicle followed by the landmarks in ``slots``."""
        return _block_index(self.vehicle_ambient, self.landmark_ambient, slots)

    def n_landmarks(self, dim: int) -> int:
        """Number of landmarks in a state of tangent dimension ``dim``."""
        return (dim - self.vehicle_dim) // self.landmark_dim

    def vehicle(self, belief: Belief) -> Belief:
        """The vehicle's marginal on ``space_of(0)``: ``mean[:a_v]`` with ``cov[:n_v, :n_v]``,
        or for a square-root belief ``sqrt[:n_v, :n_v]`` (a factor of :math:`P_{vv}` because
        the joint factor is lower triangular with the vehicle first, also when it is wide
        with deferred columns, which are zero in the vehicle rows)."""
        a, n = self.vehicle_ambient, self.vehicle_dim
        if isinstance(belief, SqrtGaussian):
            return SqrtGaussian(belief.mean[:a], belief.sqrt[:n, :n], self.space_of(0))
        return Gaussian(belief.mean[:a], belief.cov[:n, :n], self.space_of(0))


def _block_index(nv: int, nl: int, slots: Array) -> Array:
    slots = np.asarray(slots, dtype=int)
    lm = nv + nl * slots[:, None] + np.arange(nl)[None, :]
    return np.concatenate([np.arange(nv), lm.ravel()])
