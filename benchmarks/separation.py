r"""Paired separation of the filters on a drone or planar world, from the runs' own errors.

The drone kind's ``summary.json`` has no ranking block yet, and no kind of [Wang
SRCKF-SLAM]'s SLAM tests the paper's ordering SRCKF < SRUKF < SRCDKF; this runs a campaign
and ranks the filters with :mod:`slam.ranking` on per-run mean squared errors, as the kinds
with a ranking do, and tests each pair of that ordering (:func:`slam.ranking.ordering`).
Per run ``r`` and estimator ``i`` (drone):

.. math::

    m^{pos}_{i,r} = \tfrac1E \textstyle\sum_e \lVert \hat p_e - p_e \rVert^2,\qquad
    m^{yaw}_{i,r} = \tfrac1E \textstyle\sum_e (\hat\psi_e - \psi_e)^2,\qquad
    m^{lm}_{i,r} = \tfrac1L \textstyle\sum_l \lVert \hat m_l - m_l \rVert^2

(all sensor epochs; the final map; planar: 2-D position and the final map, as
``slam/kinds/planar/run.py`` ranks them), and :func:`slam.ranking.rank` gives each filter's
paired :math:`\Delta\overline{m} \pm` s.e. against the best, with the GTSAM smoother as
the reference.  The position ANEES (with its 95 % band and the share of epochs in band)
is the campaign summary's.

Run ``python -m benchmarks.separation drone-large-yaw --runs 25 --workers 2``; prints one
JSON object (``--json PATH`` also writes it) and a plain table per metric.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from slam.campaign import run_campaign
from slam.ranking import Metric, ordering, per_run, per_run_mse, rankings
from slam.registry import load_world
from slam.results import REFERENCE, CampaignResult

DEG = math.pi / 180.0
PAPER_ORDER = ("srckf", "srukf", "srcdkf")
"""[Wang SRCKF-SLAM] §5.5's ordering (narrowest error range first)."""


def drone_metrics(result: CampaignResult, names: Sequence[str]) -> list[Metric]:
    """Position (3-D), yaw (degrees) and final-landmark per-run MSEs of ``names``."""
    out = result.outcomes
    return [
        Metric("position", "position (3-D, whole run)", "m", {n: per_run(
            out, n, lambda s: float(per_run_mse(s.err_pos[None])[0])) for n in names}),
        Metric("yaw", "yaw (whole run)", "°", {n: per_run(
            out, n, lambda s: float(per_run_mse(s.err_att[None, :, 2] / DEG)[0]))
            for n in names}),
        Metric("landmarks", "landmarks (final)", "m", {n: per_run(
            out, n, lambda s: float(np.mean(s.lm_err**2)) if s.lm_err.size else np.nan)
            for n in names}),
    ]


def planar_metrics(result: CampaignResult, names: Sequence[str]) -> list[Metric]:
    """Position (2-D) and final-landmark per-run MSEs of ``names``, as the planar kind's."""
    out = result.outcomes
    return [
        Metric("position", "position", "m", {n: per_run(
            out, n, lambda s: float(per_run_mse(s.err[None, :, :2])[0])) for n in names}),
        Metric("landmarks", "landmarks (final)", "m", {n: per_run(
            out, n, lambda s: float(np.mean(s.lm_err**2)) if s.lm_err.size else np.nan)
            for n in names}),
    ]


METRICS = {"drone-slam": drone_metrics, "planar-slam": planar_metrics}


def _anees(entry: dict[str, Any]) -> dict[str, Any]:
    keys = ("anees", "anees_bounds_95", "anees_steps_inside_95", "diverged_runs")
    return {k: entry.get(k) for k in keys}


def separation(world: Any, *, runs: int | None = None, filters: Sequence[str] | None = None,
               workers: int = 1, seed: int | None = None) -> dict[str, Any]:
    """Run the campaign of ``world`` (a world or a bundled name) and return the rankings,
    the paper's orderings, ANEES and wall time as a JSON-able dict."""
    world = load_world(world) if isinstance(world, str) else world
    if world.kind not in METRICS:
        raise SystemExit(f"error: {world.name}: kind {world.kind!r}; this script ranks "
                         f"{' and '.join(METRICS)} worlds")
    t0 = time.perf_counter()
    result = run_campaign(world, filters=filters, runs=runs, seed=seed, workers=workers)
    wall = time.perf_counter() - t0
    names = list(result.summary["filters"])
    ranked = names + ([REFERENCE] if REFERENCE in result.summary.get("reference", {}) else [])
    metrics = METRICS[world.kind](result, ranked)
    blocks = rankings(metrics, names=names, reference=REFERENCE if REFERENCE in ranked else None)
    pairs = [(a, b) for i, a in enumerate(PAPER_ORDER) for b in PAPER_ORDER[i + 1:]
             if a in names and b in names]
    claims = [ordering(m, a, b) for m in metrics for a, b in pairs]
    entries = {**result.summary["filters"], **result.summary.get("reference", {})}
    return {"world": world.name, "kind": world.kind, "runs": result.summary["runs"],
            "seed": result.summary["seed"],
            "wall_s": wall, "workers": workers, "ranking": blocks, "paper_order": claims,
            "anees": {n: _anees(e) for n, e in entries.items()}}


def table(report: dict[str, Any]) -> str:
    """Plain-text tables of :func:`separation`'s rankings."""
    lines = [f"{report['world']}: {report['runs']} runs, seed {report['seed']}, "
             f"{report['wall_s']:.0f} s wall on {report['workers']} worker(s)"]
    for block in report["ranking"].values():
        lines.append(f"\n{block['label']} ({block['runs']} paired runs)")
        for n in block["order"]:
            r = block["rows"][n]
            z = "" if r["z"] is None else f"z {r['z']:.1f}"
            lines.append(f"  {r['rank']:>2} {n:<10} RMSE {r['rmse']:.4g} {block['unit']}  "
                         f"dMSE {r['delta_mse']:+.3g} ± {r['delta_se']:.2g}  "
                         f"{r['delta_percent']:+.1f} %  {z}  {r['verdict']}")
        ref = block.get("reference")
        if ref:
            lines.append(f"  smoother RMSE {ref.get('rmse')}")
    lines.append("\npaper's ordering (better - worse: dMSE ± s.e.)")
    for c in report["paper_order"]:
        lines.append(f"  {c['metric']:<10} {c['better']} < {c['worse']}: {c['mean']:+.3g} ± "
                     f"{c['se']:.2g}  {c['verdict']}")
    lines.append("\nposition ANEES [95 % band], epochs in band, diverged runs")
    for n, a in report["anees"].items():
        lines.append(f"  {n:<10} {a}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """Command line: ``WORLD [--runs N] [--filters a,b] [--workers W] [--json PATH]``."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("world")
    p.add_argument("--runs", type=int, default=None)
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--filters", default=None)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--json", type=Path, default=None)
    a = p.parse_args(argv)
    rep = separation(a.world, runs=a.runs, seed=a.seed, workers=a.workers,
                     filters=a.filters.split(",") if a.filters else None)
    text = json.dumps(rep, indent=1, default=float)
    if a.json:
        a.json.write_text(text, encoding="utf-8")
    print(table(rep))


if __name__ == "__main__":
    main()
