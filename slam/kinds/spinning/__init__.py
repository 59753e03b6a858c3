"""High-spin projectile attitude: pitch and yaw from a gyro and the magnetometer's axial
component, roll from its radial components; UKF, CKF, SRCKF, SVD-CKF, the paper's
SR-CH∞KF, UT-H∞ and the EKF against a GTSAM smoother ([Spin SR-CH∞KF])."""

from slam.kind import Deferred, Kind
from slam.kinds.spinning.world import KIND as NAME
from slam.kinds.spinning.world import NAMES, parse, work

KIND = Kind(NAME, parse, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.summary:summarize"), Deferred(f"{__name__}.report:REPORT"),
            filters=NAMES, work=work)
