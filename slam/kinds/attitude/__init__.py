"""Star-sensor satellite attitude: gyro + star sensor, quaternion SRCKF/SRUKF/SRCDKF/MEKF,
GTSAM AHRS smoother ([Wang SRCKF-SLAM] §5.1-5.2)."""

from slam.kind import Kind
from slam.kinds.attitude.report import REPORT
from slam.kinds.attitude.run import run_once, summarize_attitude
from slam.kinds.attitude.world import KIND as NAME
from slam.kinds.attitude.world import parse

KIND = Kind(NAME, parse, run_once, summarize_attitude, REPORT)
