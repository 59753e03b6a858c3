r"""The H∞ γ sweep of an alignment campaign: how the UT-H∞ / SR-CH∞KF errors move with the
bound γ, and how often the Riccati existence condition fails.

On each of the first ``[sweep] runs`` runs, every sweep filter runs once per γ of
``[sweep] gammas`` on the run's own log (so every cell is paired with the campaign's
filters on the same runs), with ``on_failure = "kalman"``: an update whose condition

.. math::

    \lambda_{\max}(P_{KF}) < \gamma^2

fails (:mod:`estimators.hinf`) is the ordinary Kalman update for that step and is
counted, never silent.  Each cell is compared, run by run, with the filter's Kalman twin
(its γ = ∞ limit: ``uthinf`` -> ``ukf``, ``srchinf`` -> ``srckf``) when the campaign ran
it, by the paired difference of the per-run level (East, North) MSE over the settled
epochs (:func:`slam.ranking.paired`).

Why little can move (measured in the report): the velocity reference carries about
:math:`10^8` rad⁻² of level information per update against about 60 rad⁻² in azimuth, so
a γ small enough to change the level covariance (:math:`\gamma^{-2}` near
:math:`10^8`) is far below the azimuth's :math:`\sigma`, where the condition fails.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimators import make_filter
from slam.kinds.alignment.scoring import ARCMIN, AlignScores
from slam.ranking import paired
from slam.results import RunOutcome

TWINS = {"uthinf": "ukf", "srchinf": "srckf"}
"""Each H∞ filter's Kalman twin (its γ = ∞ limit)."""


@dataclass(frozen=True)
class SweepCell:
    """One H∞ filter at one γ on one run: per-run MSE (arcmin²) of the level error norm
    and of the azimuth error over the settled epochs, the final error (E, N, azimuth;
    arcmin), the existence failures among the updates, and whether (why) it diverged."""

    filter: str
    gamma: float
    level_mse: float
    azimuth_mse: float
    final_arcmin: tuple[float, float, float]
    fallbacks: int
    updates: int
    diverged: bool
    failure: str | None


def settled(times: np.ndarray, from_s: float) -> np.ndarray:
    """The epochs the ranking and the sweep score: ``times >= from_s``."""
    return np.asarray(times) >= from_s


def mse_arcmin(err: np.ndarray, mask: np.ndarray) -> float:
    """Mean squared error norm (arcmin²) of ``err`` (M, k) over the finite epochs of
    ``mask``; NaN when there is none."""
    e = err[mask] / ARCMIN
    sq = np.sum(e**2, axis=1)
    sq = sq[np.isfinite(sq)]
    return float(np.mean(sq)) if sq.size else math.nan


def cell_of(s: AlignScores, gamma: float, mask: np.ndarray) -> SweepCell:
    """:class:`SweepCell` of the scores ``s`` of one sweep run."""
    final = s.err[-1] / ARCMIN
    return SweepCell(s.name, gamma, mse_arcmin(s.err[:, :2], mask), mse_arcmin(s.err[:, 2:],
                     mask), (float(final[0]), float(final[1]), float(final[2])), s.fallbacks,
                     s.updates, s.diverged, s.failure)


def sweep_filter(world: Any, name: str, gamma: float) -> Any:
    """Filter ``name`` with the world's settings but bound ``gamma`` and
    ``on_failure = "kalman"``."""
    return make_filter(name, **{**world.filters.settings_of(name), "gamma": gamma,
                                "on_failure": "kalman"})


def sweep_run(world: Any, log: Any, times: np.ndarray, run_filter: Any
              ) -> tuple[SweepCell, ...]:
    """Every (filter, γ) cell of the sweep on one run's log; ``run_filter(world, log,
    name, flt)`` runs a filter (:func:`slam.kinds.alignment.run.run_filter`)."""
    mask = settled(times, world.scoring.settled_from_s)
    return tuple(cell_of(run_filter(world, log, name, sweep_filter(world, name, g)), g, mask)
                 for name in world.sweep.filters for g in world.sweep.gammas)


def _gamma(g: float) -> float | None:
    """γ as strict JSON holds it (``None`` for ∞; the row's ``gamma_text`` says so)."""
    return None if math.isinf(g) else g


def _rms(values: Sequence[float]) -> float | None:
    v = np.asarray([x for x in values if np.isfinite(x)])
    return float(np.sqrt(np.mean(v**2))) if v.size else None


def _twin_mse(outcomes: Sequence[RunOutcome], twin: str, runs: Sequence[int],
              mask: np.ndarray) -> np.ndarray:
    out = np.full(len(runs), np.nan)
    by_run = {o.run: o for o in outcomes}
    for i, r in enumerate(runs):
        s = by_run[r].scores.get(twin)
        if s is not None and not s.diverged:
            out[i] = mse_arcmin(s.err[:, :2], mask)
    return out


def summarize_sweep(world: Any, outcomes: Sequence[RunOutcome], times: np.ndarray
                    ) -> dict[str, Any]:
    """``summary.json``'s ``gamma_sweep``: per filter and γ, the runs, diverged runs (with
    reasons), settled level and azimuth RMSE, final East / North / azimuth RMS (arcmin),
    existence failures / updates and the runs with any, and the paired level ΔMSE against
    the Kalman twin (``vs_twin``; ``None`` with its reason when the twin did not run)."""
    spec = world.sweep
    mask = settled(times, world.scoring.settled_from_s)
    done = [o for o in outcomes if getattr(o, "sweep", ())]
    rows = []
    for name in spec.filters:
        twin = TWINS[name]
        for g in spec.gammas:
            cells = [(o.run, c) for o in done for c in o.sweep
                     if c.filter == name and c.gamma == g]
            good = [(r, c) for r, c in cells if not c.diverged]
            row: dict[str, Any] = {
                "filter": name, "gamma": _gamma(g), "gamma_text": "∞" if math.isinf(g)
                else f"{g:g}", "runs": len(cells), "diverged": len(cells) - len(good),
                "failures": sorted({c.failure for _, c in cells if c.failure}),
                "level_rmse_arcmin": _rms([math.sqrt(c.level_mse) for _, c in good]),
                "azimuth_rmse_arcmin": _rms([math.sqrt(c.azimuth_mse) for _, c in good]),
                "final_rms_arcmin": {a: _rms([c.final_arcmin[i] for _, c in good])
                                     for i, a in enumerate(("east", "north", "azimuth"))},
                "fallbacks": sum(c.fallbacks for _, c in cells),
                "updates": sum(c.updates for _, c in cells),
                "runs_with_fallbacks": sum(c.fallbacks > 0 for _, c in cells)}
            if any(twin in o.scores for o in done):
                mine = np.array([c.level_mse if not c.diverged else np.nan for _, c in cells])
                d = paired(mine, _twin_mse(done, twin, [r for r, _ in cells], mask))
                row["vs_twin"] = {"twin": twin, **d}
            else:
                row["vs_twin"] = None
                row["vs_twin_reason"] = f"{twin} (the γ = ∞ twin) is not among the filters run"
            rows.append(row)
    return {"gammas": [_gamma(g) for g in spec.gammas], "filters": list(spec.filters),
            "runs": len(done), "on_failure": "kalman",
            "settled_from_s": world.scoring.settled_from_s, "rows": rows}
