"""Star-sensor satellite attitude: gyro + star sensor, quaternion SRCKF/SRUKF/SRCDKF/MEKF,
GTSAM AHRS smoother ([Wang SRCKF-SLAM] §5.1-5.2)."""

from slam.kind import Deferred, Kind
from slam.kinds.attitude.world import KIND as NAME
from slam.kinds.attitude.world import parse, work

KIND = Kind(NAME, parse, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.run:summarize_attitude"), Deferred(f"{__name__}.report:REPORT"),
            work=work, run_batch=Deferred(f"{__name__}.run:run_batch"))
