r"""Recorded attitude logs (GTSAM's ``EqFdata.csv`` layout: gyro, direction sensors, truth)
as a scenario kind: ``slam run --log eqf`` (the file the gtsam wheel ships) or
``--log FILE.csv``.  The star-sensor kind's attitude filters and a GTSAM AHRS smoother on
the same log, scored against its truth and the filters against the smoother
(:mod:`slam.kinds.attitude_log.run`; the layout: :mod:`slam.kinds.attitude_log.log`)."""

from slam.kind import Deferred, Kind
from slam.kinds.attitude_log.world import ATTITUDE_LOG_FILTERS, open_log, work
from slam.kinds.attitude_log.world import KIND as NAME


def _no_world_file(data, name, source, base):
    from worlds.schema import WorldError

    raise WorldError(source, "kind", "recorded attitude logs are read with `slam run --log "
                     "FILE`, not from a world file", data.get("kind"))


KIND = Kind(NAME, _no_world_file, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.summary:summarize"), Deferred(f"{__name__}.report:REPORT"),
            open_log=open_log, filters=ATTITUDE_LOG_FILTERS, work=work)
