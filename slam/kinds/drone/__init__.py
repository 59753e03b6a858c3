"""Quaternion SINS/SLAM drone over terrain: strapdown IMU, range/azimuth/elevation
landmarks, joint-state SLAM, CombinedImuFactor smoother ([Wang SRCKF-SLAM])."""

from slam.kind import Deferred, Kind
from slam.kinds.drone.variants import DRONE_FILTERS, DRONE_LOCAL_FILTERS
from slam.kinds.drone.world import KIND as NAME
from slam.kinds.drone.world import MODES, parse, work

KIND = Kind(NAME, parse, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.run:summarize_drone"), Deferred(f"{__name__}.report:REPORT"),
            MODES, {"local": DRONE_LOCAL_FILTERS}, filters=DRONE_FILTERS, work=work,
            run_batch=Deferred(f"{__name__}.run:run_batch"))
