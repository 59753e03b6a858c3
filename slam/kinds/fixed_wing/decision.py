"""The decision part of a fixed-wing campaign's summary ([Fixed-wing EA-UKF]): the paired
rankings (:func:`slam.decision.decide`) and the paper's orderings tested run by run.

Headline metrics, each a per-run mean squared error over the estimator's own epochs
(INS and the smoother: the GNSS epochs; EA: the accelerometer/magnetometer epochs):

* ``position`` - the INS filters' 3-D position error norm (m); the EA filters carry none;
* ``attitude`` - every filter's roll / pitch / heading error norm (deg);
* ``heading`` - every filter's heading error (deg), the paper's Table 1 column, where the
  EA filters (magnetometer heading) and the INS filters (heading from the GNSS-aided
  mechanisation) are ranked together, as the paper sets its EA-UKF beside its INS/UQ-CKF.

The GTSAM smoother is the reference; the consistency score is each filter's own NEES
(9-dof ``[δp, δv, δθ]`` for INS, 3-dof Euler for EA).  The paper's orderings (Table 1:
its CKF beats its UKF by 1.9-3.1× in every column; the conclusion: the INS/UQ-CKF beats
the EA-UKF) are tested as ``ins-ckf`` against ``ins-ukf`` on position and heading and
``ins-ckf`` against ``ea-ukf`` on heading (:func:`slam.ranking.ordering`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from slam.decision import Consistency, decide
from slam.ranking import Metric, ordering, per_run
from slam.results import REFERENCE, RunOutcome

DEG = 180.0 / np.pi
ORDERINGS = (("position", "ins-ckf", "ins-ukf"), ("heading", "ins-ckf", "ins-ukf"),
             ("heading", "ins-ckf", "ea-ukf"))
"""(metric, claimed better, claimed worse): the paper's orderings tested."""

CONSISTENCY = Consistency(label="own-state (INS: 9-dof position, velocity, attitude; EA: "
                                "3-dof Euler)")


def _mse(x: np.ndarray) -> float:
    """Mean over the finite epochs of the squared error norm of ``x`` (M, k) or (M,)."""
    sq = np.sum(x**2, axis=1) if x.ndim == 2 else x**2
    sq = sq[np.isfinite(sq)]
    return float(np.mean(sq)) if sq.size else np.nan


def metrics(outcomes: list[RunOutcome], names: list[str]) -> list[Metric]:
    """The headline metrics of the module docstring over ``names`` (filters and the
    smoother); position only for the estimators that carry one."""
    with_pos = [n for n in names if not n.startswith("ea-")]
    return [
        Metric("position", "INS position (3-D)", "m",
               {n: per_run(outcomes, n, lambda s: _mse(s.err_pos)) for n in with_pos}),
        Metric("attitude", "attitude (roll, pitch, heading)", "°",
               {n: per_run(outcomes, n, lambda s: _mse(s.err_att * DEG)) for n in names}),
        Metric("heading", "heading", "°",
               {n: per_run(outcomes, n, lambda s: _mse(s.err_att[:, 2] * DEG))
                for n in names}),
    ]


def decide_fixed_wing(world: Any, outcomes: list[RunOutcome], filters: list[str],
                      summary: dict[str, Any]) -> dict[str, Any]:
    """``summary`` with the ranking, headline, settings and the paper's orderings."""
    ms = metrics(outcomes, [*filters, REFERENCE])
    by_key = {m.key: m for m in ms}
    tested = [ordering(by_key[k], a, b) for k, a, b in ORDERINGS
              if a in filters and b in filters]
    fs = world.filters
    return decide({**summary, "paper_ordering": tested}, ms, filters=filters,
                  consistency=CONSISTENCY, tuned=fs)
