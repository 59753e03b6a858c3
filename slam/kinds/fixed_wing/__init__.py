"""Fixed-wing UAV attitude: EA-UKF/CKF (Euler angles, accelerometer + magnetometer) vs
INS/UQ-CKF/UKF (unit-quaternion INS error state, GNSS aiding), SRCKF and EKF baselines,
GTSAM CombinedImuFactor smoother ([Fixed-wing EA-UKF])."""

from slam.kind import Kind
from slam.kinds.fixed_wing.report import REPORT
from slam.kinds.fixed_wing.run import run_once, summarize
from slam.kinds.fixed_wing.world import FILTERS, parse
from slam.kinds.fixed_wing.world import KIND as NAME

KIND = Kind(NAME, parse, run_once, summarize, REPORT, filters=FILTERS)
