"""The decision part of a star-sensor campaign's summary ([Wang SRCKF-SLAM] §5.1-5.2): the
paired rankings (:func:`slam.decision.decide`) and the paper's Table 2 ordering tested run
by run (:func:`slam.ranking.ordering`).

Headline metrics, per run over every star epoch (Table 2 averages the whole run):

* ``attitude`` - the Z-X-Y Euler attitude error (arcsec; the per-run MSE sums roll, pitch
  and yaw);
* ``bias`` - the gyro-bias error ((deg/h)²).

The GTSAM AHRS smoother is the reference; the consistency score is the 6-dof ANEES of
attitude and bias (:func:`slam.kinds.attitude.run.summarize_scores`).  Table 2 puts the
mean absolute errors in the order SRCKF < SRUKF < SRCDKF on every axis: tested as
``srckf`` against ``srukf``, ``srukf`` against ``srcdkf`` and ``srckf`` against ``srcdkf``
on the attitude metric, where those filters ran.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from slam.decision import Consistency, decide
from slam.ranking import Metric, ordering, per_run, per_run_mse
from slam.results import REFERENCE, RunOutcome
from worlds.units import ARCSEC, DEG_H

ORDERINGS = (("attitude", "srckf", "srukf"), ("attitude", "srukf", "srcdkf"),
             ("attitude", "srckf", "srcdkf"))
"""(metric, claimed better, claimed worse): Table 2's ordering, pair by pair."""

CONSISTENCY = Consistency(label="attitude + bias (6-dof)")
"""The headline consistency score: the 6-dof ANEES of the summary entries."""


def headline_metrics(outcomes: Sequence[RunOutcome], names: Sequence[str]) -> list[Metric]:
    """The metrics of the module docstring for the estimators ``names``."""
    return [
        Metric("attitude", "attitude (Z-X-Y Euler, whole run)", "″", {
            n: per_run(outcomes, n, lambda s: float(per_run_mse(s.err_euler[None] / ARCSEC)[0]))
            for n in names}),
        Metric("bias", "gyro bias (whole run)", "deg/h", {
            n: per_run(outcomes, n, lambda s: float(per_run_mse(s.err_bias[None] / DEG_H)[0]))
            for n in names}),
    ]


def decide_attitude(world: Any, outcomes: Sequence[RunOutcome], filters: Sequence[str],
                    summary: dict[str, Any]) -> dict[str, Any]:
    """``summary`` with the rankings, headline, settings and the paper's ordering tested."""
    ms = headline_metrics(outcomes, [*filters, REFERENCE])
    by_key = {m.key: m for m in ms}
    tested = [ordering(by_key[k], a, b) for k, a, b in ORDERINGS
              if a in filters and b in filters]
    fs = world.filters
    return decide({**summary, "paper_ordering": tested}, ms, filters=list(filters),
                  consistency=CONSISTENCY, tuned=fs)
