"""Ship SINS quaternion attitude: FOG + vector observations, HoMM-UKF vs UKF vs CDKF with
the pseudo-observation and the eigenvector quaternion mean, SRCKF and the MEKF on the
manifold, GTSAM AHRS smoother ([Ding 2017])."""

from slam.kind import Deferred, Kind
from slam.kinds.ship.world import KIND as NAME
from slam.kinds.ship.world import parse, work

KIND = Kind(NAME, parse, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.run:summarize"), Deferred(f"{__name__}.report:REPORT"), work=work)
