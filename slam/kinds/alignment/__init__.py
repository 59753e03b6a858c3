"""Missile-borne SINS initial alignment on a swaying launcher under wind: the additive
quaternion error model with the UT-H∞ filter vs the UKF (plus SRCKF, SR-CH∞KF, EKF) and a
GTSAM CombinedImuFactor smoother ([Wu-Wang 2014])."""

from slam.kind import Deferred, Kind
from slam.kinds.alignment.world import KIND as NAME
from slam.kinds.alignment.world import NAMES, parse, work

KIND = Kind(NAME, parse, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.summary:summarize"), Deferred(f"{__name__}.report:REPORT"),
            filters=NAMES, work=work)
