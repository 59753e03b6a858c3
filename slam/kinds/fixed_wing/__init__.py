"""Fixed-wing UAV attitude: EA-UKF/CKF (Euler angles, accelerometer + magnetometer) vs
INS/UQ-CKF/UKF (unit-quaternion INS error state, GNSS aiding), SRCKF and EKF baselines,
GTSAM CombinedImuFactor smoother ([Fixed-wing EA-UKF])."""

from slam.kind import Deferred, Kind
from slam.kinds.fixed_wing.world import FILTERS, parse, work
from slam.kinds.fixed_wing.world import KIND as NAME

KIND = Kind(NAME, parse, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.run:summarize"), Deferred(f"{__name__}.report:REPORT"),
            filters=FILTERS, work=work)
