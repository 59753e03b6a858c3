r"""Recorded IMU + GNSS logs as a scenario kind: ``slam run --log kitti`` or ``--log FILE.csv``.

Logs
----
``kitti``: GTSAM's bundled KITTI drive (``gtsam.findExampleDataFile``: 468 s of ~100 Hz
IMU, 1 Hz GPS), its metadata read as :data:`slam.kinds.ins_log.settings.KITTI_READING`
says (a folder holding the three files reads the same way).

``FILE.csv`` with the sidecar ``FILE.toml`` (:mod:`slam.kinds.ins_log.settings`: frames
ENU/FLU or NED/FRD, units, the IMU noise in datasheet units, GNSS σ, site, prior,
alignment, filters).  The CSV: one header line naming the columns (any order), then one
row per IMU reading, comma-separated, ``#`` lines skipped::

    t,gx,gy,gz,ax,ay,az,px,py,pz,vx,vy,vz,sp,sv,tx,ty,tz
    0.00,0.001,-0.002,0.010,0.12,-0.05,9.79,0.0,0.0,0.0,,,,,,,,
    0.01,0.001,-0.002,0.011,0.13,-0.04,9.80,,,,,,,,,,,

``t`` (s, strictly increasing), gyro ``gx gy gz`` and specific force ``ax ay az`` in the
sidecar's body frame and units, each the average over ``(t_prev, t]`` (the first row's
reading is not used); a GNSS fix at ``t`` where ``px py pz`` (m, the navigation frame, a
local level frame whose origin the user chooses) and/or ``vx vy vz`` (m/s) are filled,
with optional per-fix σ ``sp`` (m) and ``sv`` (m/s); empty fields elsewhere.  Position
columns are required; velocity columns optional.  Optional truth ``tx ty tz`` (m, the
navigation frame) on the fix rows adds the usual scores against truth (position RMSE and
NEES at the fix epochs).

What runs
---------
Time stamps drive everything: the readings are held over their own intervals, cut at the
fix times (any number of readings between fixes, gaps held and counted).  The INS filters
(:mod:`nav.ins`, 15 states, through :func:`estimators.make_filter`) start at the coarse
alignment (:mod:`nav.alignment`: levelling from the mean specific force over the epoch
before the first fix at ``min_speed_mps`` from the previous one, heading from that track);
one epoch per fix, updated with the GNSS position (and velocity) when the fix is used.
The GTSAM smoother (:mod:`slam.kinds.ins_log.reference`) runs on the same log from the same
prior: online (iSAM2 updated at every fix) and smoothed (its final estimate).

Scoring without truth (:mod:`slam.kinds.ins_log.scoring`): ``--holdout K`` withholds every
``K``-th fix from every estimator and scores the position error there from fix 60;
``--outage START:LENGTH`` (repeatable) drops every fix in the window and scores the drift
at its last; NIS per window of updates against its 95 % band, with a warning when the
noise is badly scaled.
"""

from slam.kind import Deferred, Kind
from slam.kinds.ins_log.settings import FILTERS
from slam.kinds.ins_log.world import KIND as NAME
from slam.kinds.ins_log.world import open_log, reads, work

__all__ = ["KIND", "reads"]


def _no_world_file(data, name, source, base):
    from worlds.schema import WorldError

    raise WorldError(source, "kind", "IMU + GNSS logs are read with `slam run --log FILE`, "
                     "not from a world file", data.get("kind"))


KIND = Kind(NAME, _no_world_file, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.run:summarize"), Deferred(f"{__name__}.report:REPORT"), (),
            None, open_log, filters=FILTERS, work=work)
