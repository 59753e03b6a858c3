"""Quaternion SINS/SLAM drone over terrain: strapdown IMU, range/azimuth/elevation
landmarks, joint-state SLAM, CombinedImuFactor smoother ([Wang SRCKF-SLAM])."""

from slam.kind import Kind
from slam.kinds.drone.report import REPORT
from slam.kinds.drone.run import run_once, summarize_drone
from slam.kinds.drone.variants import DRONE_FILTERS, DRONE_LOCAL_FILTERS
from slam.kinds.drone.world import KIND as NAME
from slam.kinds.drone.world import MODES, parse

KIND = Kind(NAME, parse, run_once, summarize_drone, REPORT, MODES, {"local": DRONE_LOCAL_FILTERS},
            filters=DRONE_FILTERS)
