"""Consistent planar SLAM (issue #17, planar part): the invariant and FEJ variants against
their standard twins on ``webmap`` and on Victoria Park.

Prints one JSON object with up to three sections:

``webmap``
    a Monte Carlo campaign of the bundled ``webmap`` world (2 loops) for ``ekf``,
    ``ekf-fej``, ``ekf-inv``, ``srckf``, ``srckf-inv``, ``srukf-inv``: per filter the ANEES
    with its 95 % band, the share of epochs in band, the project's verdict
    (:func:`slam.render.tables.verdict`), landmark RMSE and its ratio to the GTSAM
    smoother's, pose RMSE, wall time per epoch (loaded machine);
``timing``
    CPU time (``time.process_time``) per epoch of every filter on one webmap log (seed 0),
    BLAS on one thread, and each variant's ratio to its standard twin (same process);
``cost``
    the invariant variants' cost against their twins, alternating and repeated
    (:func:`benchmarks.invariant_cost.invariant_cost`; issue #17's target: <= 1.3x);
``victoria``
    GTSAM's ``victoria_park.txt`` in ``joint`` mode (default ``ekf``, ``ekf-fej``,
    ``ekf-inv``, ``srckf-inv``; and ``srckf``, ``ekf-inv``, ``srckf-inv``, ``srukf-inv`` in
    ``local`` mode, the log's default): per
    filter the map rotation of the best rigid fit onto the smoother's landmarks, median/max
    landmark distance (raw and after the fit), the final heading σ.

Run ``python -m benchmarks.consistent_slam --runs 20 --workers 2`` (add ``--association nn``,
``--mode local``, ``--filters a,b``, ``--noise-scale 0.1``,
``--timing``, ``--cost [--cost-reps 3]``, ``--victoria``, ``--no-webmap``); ``--summary PATH``
reduces the ``summary.json`` of an earlier ``slam run webmap`` instead of running the campaign.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

FILTERS = ("ekf", "ekf-fej", "ekf-inv", "srckf", "srckf-inv", "srukf-inv")
VICTORIA = ("ekf", "ekf-fej", "ekf-inv", "srckf-inv")
VICTORIA_LOCAL = ("srckf", "ekf-inv", "srckf-inv", "srukf-inv")


def _row(entry: dict[str, Any], ref: dict[str, Any]) -> dict[str, Any]:
    from slam.render.tables import verdict

    lm, lm_ref = entry.get("landmark_rmse_m"), ref.get("landmark_rmse_m")
    return {
        "anees": entry.get("anees"), "band_95": entry.get("anees_bounds_95"),
        "epochs_in_band": entry.get("anees_steps_inside_95"), "verdict": verdict(entry),
        "landmark_rmse_m": lm, "smoother_landmark_rmse_m": lm_ref,
        "landmark_rmse_over_smoother": None if lm is None or not lm_ref else lm / lm_ref,
        "pos_rmse_m": entry.get("pos_rmse_m"), "heading_rmse_deg": entry.get("heading_rmse_deg"),
        "wall_time_per_epoch_s": entry.get("time_per_step_s"),
        "diverged_runs": entry.get("diverged_runs"),
    }


def reduce_summary(summary: dict[str, Any]) -> dict[str, Any]:
    """The figures of a planar campaign's ``summary.json``."""
    ref = next(iter(summary["reference"].values()))
    rows = {name: _row(e, ref) for name, e in summary["filters"].items()}
    rows["gtsam"] = _row(ref, ref)
    return {"world": summary["world"], "runs": summary["runs"], "seed": summary["seed"],
            "mode": summary.get("mode"), "filters": rows}


def webmap(runs: int, workers: int, association: str, filters=FILTERS, mode: str = "joint",
           noise_scale: float = 1.0) -> dict[str, Any]:
    """Run the campaign (seed 0) in ``mode`` and reduce it; ``noise_scale`` multiplies the
    four noise σ (range, bearing, speed, steering: the same scale on the truth's noise and
    on the filters' models), to separate the problem's nonlinearity from the filters'."""
    from slam.campaign import run_campaign
    from slam.registry import load_world

    world = load_world("webmap")
    world = replace(world, filters=replace(world.filters, association=association, mode=mode))
    if noise_scale != 1.0:
        k, sen, noi = noise_scale, world.sensor, world.noise
        world = replace(world, sensor=replace(sen, sigma_range_m=k * sen.sigma_range_m,
                                              sigma_bearing_rad=k * sen.sigma_bearing_rad),
                        noise=replace(noi, sigma_speed_mps=k * noi.sigma_speed_mps,
                                      sigma_steer_rad=k * noi.sigma_steer_rad))
    res = run_campaign(world, filters=list(filters), runs=runs, seed=0, workers=workers)
    out = reduce_summary(res.summary)
    out["association"] = association
    out["mode"] = mode
    out["noise_scale"] = noise_scale
    return out


def timing(filters=FILTERS) -> dict[str, Any]:
    """CPU time per epoch on one webmap log, each variant against its standard twin."""
    from estimators.threads import single_thread_blas
    from slam.kinds.planar.simulate import simulate_planar
    from slam.kinds.planar.slam import run_slam
    from slam.kinds.planar.variants import split_variant
    from slam.registry import load_world

    world = load_world("webmap")
    log = simulate_planar(world, np.random.default_rng(np.random.SeedSequence(0).spawn(1)[0]))
    names = sorted(set(filters) | {split_variant(n)[0] for n in filters})
    cpu: dict[str, float] = {}
    with single_thread_blas():
        for name in names:
            t0 = time.process_time()
            r = run_slam(log, name, epoch_steps=world.sensor.period_steps)
            cpu[name] = (time.process_time() - t0) / (len(r.steps) - 1)
    rows = {}
    for name in names:
        base = split_variant(name)[0]
        rows[name] = {"cpu_s_per_epoch": cpu[name], "twin": base,
                      "ratio_to_twin": cpu[name] / cpu[base]}
    return {"note": "CPU seconds per epoch (whole run incl. recording), one run, loaded "
                    "machine; compare ratios only", "filters": rows}


def victoria(filters=VICTORIA, local=VICTORIA_LOCAL) -> dict[str, Any]:
    """Victoria Park: ``filters`` in joint mode and ``local`` in local mode (the log's
    default), scored against the smoother."""
    import gtsam

    from estimators.threads import single_thread_blas
    from slam.failures import run_reference
    from slam.kinds.recorded.log import read_odometry_log
    from slam.kinds.recorded.models import run_recorded
    from slam.kinds.recorded.reference import smooth_recorded
    from slam.kinds.recorded.scoring import score_filter

    log = read_odometry_log(Path(gtsam.findExampleDataFile("victoria_park.txt")))
    ref, failure = run_reference(smooth_recorded, log, final_marginal=True)
    rows: dict[str, Any] = {}
    runs = [(n, "joint") for n in filters] + [(n, "local") for n in local]
    with single_thread_blas():
        for name, mode in runs:
            t0 = time.process_time()
            r = run_recorded(log, name, mode=mode)
            row = score_filter(r, ref)
            row["cpu_s"] = time.process_time() - t0
            row["final_heading_sigma_deg"] = math.degrees(math.sqrt(r.pose_cov[-1, 2, 2]))
            rows[f"{name} ({mode})"] = row
    final = getattr(ref, "final_pose_cov", None)
    return {"smoother_failure": failure, "filters": rows,
            "smoother_final_heading_sigma_deg":
                None if final is None else math.degrees(math.sqrt(final[2, 2]))}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--association", choices=("known", "nn"), default="known")
    ap.add_argument("--mode", choices=("joint", "local"), default="joint")
    ap.add_argument("--filters", default=",".join(FILTERS), help="webmap filters")
    ap.add_argument("--noise-scale", type=float, default=1.0,
                    help="multiply webmap's four noise σ (truth and models) by this")
    ap.add_argument("--summary", type=Path, help="reduce this summary.json instead")
    ap.add_argument("--no-webmap", action="store_true")
    ap.add_argument("--timing", action="store_true")
    ap.add_argument("--cost", action="store_true",
                    help="invariant / standard twin CPU time per epoch, alternating")
    ap.add_argument("--cost-reps", type=int, default=3)
    ap.add_argument("--victoria", action="store_true")
    ap.add_argument("--victoria-filters", default=",".join(VICTORIA),
                    help="joint-mode filters on Victoria Park")
    ap.add_argument("--victoria-local", default=",".join(VICTORIA_LOCAL),
                    help="local-mode filters on Victoria Park")
    a = ap.parse_args(argv)
    out: dict[str, Any] = {}
    if a.summary is not None:
        out["webmap"] = reduce_summary(json.loads(a.summary.read_text()))
    elif not a.no_webmap:
        out["webmap"] = webmap(a.runs, a.workers, a.association, tuple(a.filters.split(",")),
                               a.mode, a.noise_scale)
    if a.timing:
        out["timing"] = timing()
    if a.cost:
        from benchmarks.invariant_cost import invariant_cost

        out["cost"] = invariant_cost(reps=a.cost_reps)
    if a.victoria:
        out["victoria"] = victoria(tuple(a.victoria_filters.split(",")),
                                   tuple(f for f in a.victoria_local.split(",") if f))
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
