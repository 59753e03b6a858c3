"""Planar SLAM in Bailey's world: car model, range-bearing sensor, EKF/sigma-point SLAM in
joint or local mode, Pose2/Point2 GTSAM smoother ([Wang SRCKF-SLAM] §5.3-5.5)."""

from slam.kind import Deferred, Kind
from slam.kinds.planar.variants import PLANAR_FILTERS
from slam.kinds.planar.world import KIND as NAME
from slam.kinds.planar.world import LOCAL_FILTERS, MODES, parse, work

KIND = Kind(NAME, parse, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.run:summarize_planar"), Deferred(f"{__name__}.report:REPORT"),
            MODES, {"local": LOCAL_FILTERS}, filters=PLANAR_FILTERS, work=work,
            run_batch=Deferred(f"{__name__}.run:run_batch"))
