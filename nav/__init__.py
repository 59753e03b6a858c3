"""Navigation library: rotations (quaternions, DCMs, Euler angles) and state spaces.

See :mod:`nav.quaternion` for the fixed conventions (Hamilton, scalar-first,
``q_nb`` maps body to navigation, right/body-frame attitude errors, radians).
"""

from .euler import (
    dcm_nb_from_paper,
    euler_zxy_to_q,
    euler_zyx_to_q,
    q_from_paper,
    q_to_euler_zxy,
    q_to_euler_zyx,
    q_to_paper,
)
from .quaternion import (
    dcm_to_q,
    dcm_to_rotvec,
    omega_matrix,
    qconj,
    qexp,
    qlog,
    qmul,
    qnormalize,
    qpropagate,
    qrotate,
    qto_dcm,
    rotvec_to_dcm,
    skew,
)
from .spaces import UnitQuaternion

__all__ = [
    "UnitQuaternion",
    "dcm_nb_from_paper",
    "dcm_to_q",
    "dcm_to_rotvec",
    "euler_zxy_to_q",
    "euler_zyx_to_q",
    "omega_matrix",
    "q_from_paper",
    "q_to_euler_zxy",
    "q_to_euler_zyx",
    "q_to_paper",
    "qconj",
    "qexp",
    "qlog",
    "qmul",
    "qnormalize",
    "qpropagate",
    "qrotate",
    "qto_dcm",
    "rotvec_to_dcm",
    "skew",
]
