"""Ship SINS quaternion attitude: FOG + vector observations, HoMM-UKF vs UKF vs CDKF with
the pseudo-observation and the eigenvector quaternion mean, SRCKF and the MEKF on the
manifold, GTSAM AHRS smoother ([Ding 2017])."""

from slam.kind import Kind
from slam.kinds.ship.report import REPORT
from slam.kinds.ship.run import run_once, summarize
from slam.kinds.ship.world import KIND as NAME
from slam.kinds.ship.world import parse

KIND = Kind(NAME, parse, run_once, summarize, REPORT)
