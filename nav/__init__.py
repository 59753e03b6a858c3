"""Navigation library: rotations (quaternions, DCMs, Euler angles) and state spaces.

See :mod:`nav.quaternion` for the fixed conventions (Hamilton, scalar-first,
``q_nb`` maps body to navigation, right/body-frame attitude errors, radians).
The INS library: :mod:`nav.strapdown` (mechanisation, per-sample intervals),
:mod:`nav.gravity` (WGS-84 normal gravity), :mod:`nav.imu_noise` (datasheet units to
PSDs; random-walk and first-order Markov biases), :mod:`nav.gnss` (GNSS position /
velocity measurements, lever arm), :mod:`nav.alignment` (levelling, track heading) and
:mod:`nav.ins` (the 15-state INS error-state model for GNSS aiding).
The package re-exports the rotation functions of :mod:`nav.quaternion` and
:mod:`nav.euler` and the :class:`~nav.spaces.UnitQuaternion` space.
"""

from . import euler, quaternion
from .euler import *  # noqa: F403  (the names in euler.__all__)
from .quaternion import *  # noqa: F403  (the names in quaternion.__all__)
from .spaces import UnitQuaternion as UnitQuaternion

__all__ = sorted(["UnitQuaternion", *euler.__all__, *quaternion.__all__])
