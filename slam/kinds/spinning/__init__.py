"""High-spin projectile attitude: pitch and yaw from a gyro and the magnetometer's axial
component, roll from its radial components; UKF, CKF, SRCKF, SVD-CKF, the paper's
SR-CH∞KF, UT-H∞ and the EKF against a GTSAM smoother ([Spin SR-CH∞KF])."""

from slam.kind import Kind
from slam.kinds.spinning.report import REPORT
from slam.kinds.spinning.run import run_once
from slam.kinds.spinning.summary import summarize
from slam.kinds.spinning.world import KIND as NAME
from slam.kinds.spinning.world import NAMES, parse

KIND = Kind(NAME, parse, run_once, summarize, REPORT, filters=NAMES)
