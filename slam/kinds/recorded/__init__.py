r"""Recorded planar SLAM logs (GTSAM's text format) as a scenario kind: ``slam run --log FILE``.

File format (one record a line; blank lines and ``#`` comments are skipped)::

    ODOMETRY i j dx dy dθ  c_xx c_xy c_xθ c_yy c_yθ c_θθ
    LANDMARK i l x y  c_xx c_xy c_yy

``ODOMETRY`` is the motion from pose ``i`` to pose ``j`` in the frame of pose ``i``
(metres, radians) with the upper triangle, row by row, of its covariance in GTSAM's
between-factor tangent (body frame of the motion, right perturbation:
:math:`T_j = T_i\,\Delta\,\mathrm{Exp}(w)`, :math:`w \sim N(0, C)`).  ``LANDMARK`` is
landmark ``l`` seen from pose ``i`` as a Cartesian point ``(x, y)`` in the robot frame,
with the upper triangle of its covariance.  Landmark ids are known; pose and landmark ids
share one integer space, so pose ids have gaps.  (This is the layout of the wheel's
``victoria_park.txt``: ``ODOMETRY`` covariance diag(1e-4, 4e-6, 4e-6), ``LANDMARK``
covariance diag(0.4, 0.4); GTSAM's own ``load2D`` reads the same triangles as covariances.)
The odometry records must form one chain (each starts where the previous one ended).

Filter models (state :math:`[x, y, φ, m_1, \dots]`, the layout of :mod:`slam.kinds.planar.models`)

.. math::

    T' = T\,\Delta\,\mathrm{Exp}(w)\ \text{(per odometry step, noise entering the
    increment)},\qquad
    z = R(φ)^\top (m - p) + v,\qquad
    m = p + R(φ)\,(z + v)\ \text{(augmentation)}.

The filters start at the first pose, known exactly (the origin), as the smoother's prior.

The smoother (:func:`smooth_recorded`)
    ``BetweenFactorPose2`` per odometry record with the file's covariance, and one
    ``BearingRangeFactor2D`` per landmark record: the GTSAM 4.3 wheel has no built-in
    factor for a Cartesian point in a pose's frame (``KnownLandmarkFactorPose2`` holds the
    landmark fixed), so the measurement is converted to bearing :math:`b = \mathrm{atan2}(y,
    x)` and range :math:`r = \lVert(x, y)\rVert` with the first-order covariance
    :math:`J C J^\top`, :math:`J = \partial(b, r)/\partial(x, y)` - for an isotropic
    :math:`C = σ^2 I` that is :math:`σ_b = σ/r`, :math:`σ_r = σ`, and the two factors' errors
    agree to second order in the residual.  A weak prior (1e-6) holds the first pose at
    the origin.  Levenberg-Marquardt from dead reckoning falls into a wrong minimum on a
    long log, so the poses are fed one by one to iSAM2 (each new pose initialised from the
    current estimate of the previous one and the odometry, each new landmark from its
    first sighting), and a final batch LM polishes the result; ``½χ²`` (``graph.error``)
    is reported after each.

Scoring (:func:`score_filter`)
    Without ground truth the filters are scored against the smoother: per filter the
    median and maximum distance of its final landmarks to the smoother's, the distance of
    its final pose to the smoother's final pose, its pose RMSE to the smoother over the
    filter epochs, and its whole-log time.
"""

from slam.kind import Deferred, Kind
from slam.kinds.planar.variants import PLANAR_FILTERS, PLANAR_LOCAL_FILTERS
from slam.kinds.recorded.world import KIND as NAME
from slam.kinds.recorded.world import MODES, open_log, work


def _no_world_file(data, name, source, base):
    from worlds.schema import WorldError

    raise WorldError(source, "kind", "recorded logs are read with `slam run --log FILE`, "
                     "not from a world file", data.get("kind"))


KIND = Kind(NAME, _no_world_file, Deferred(f"{__name__}.run:run_once"),
            Deferred(f"{__name__}.run:summarize"), Deferred(f"{__name__}.report:REPORT"), MODES,
            {"local": PLANAR_LOCAL_FILTERS}, open_log, filters=PLANAR_FILTERS,
            work=work)
