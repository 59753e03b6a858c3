"""Report of a recorded-log run (``slam run --log``): the filters against the GTSAM smoother
on the same measurements (a log has no ground truth), figures
(:mod:`slam.kinds.recorded.figures`) and TUM trajectories.

    trajectories.png, aligned_map.png, pose_diff.png, map_state.png
    <name>.tum   every estimator's poses (filters at their epochs, the smoother and the
                 odometry at every pose); the time column is the pose index
    <name>.cov.txt  beside the filters' and the online row's: the pose index, then the
                 3 x 3 [x, y, heading] covariance row-major, one line per pose of the file
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from slam.kind import Deferred
from slam.kinds.planar.report import tum_text
from slam.kinds.recorded.log import DEFAULT_MAX_EPOCH_STEPS
from slam.render import tum
from slam.render.decision import decision_sections, decision_text, rank_column
from slam.render.document import KindReport, Link, Section
from slam.render.output import write_tum
from slam.render.tables import (
    EPOCH_TIME,
    MISSING,
    RUN_TIME,
    estimator_entries,
    failure_notes,
    num,
    plain_table,
    wrap,
)
from slam.results import REFERENCE, CampaignResult

LOG_COLUMNS = ("estimator", "rank\npos", "lm dist\nmed (m)", "lm dist\nmax (m)",
               "aligned\nmed (m)", "map rot.\n(deg)", "final\npose (m)", "pose\nRMSE (m)",
               RUN_TIME,
               "iSAM2 /\nfilter", "diverged")


ONLINE_LOG_COLUMNS = (*LOG_COLUMNS[:8], EPOCH_TIME, "final\nσθ (°)", "diverged")
"""The columns with the online row (``--online``): time per epoch and the final heading σ
in place of the time per run and the iSAM2 / filter ratio."""


def _row(name: str, e: dict[str, Any], rank: str, online: bool) -> list[str]:
    diverged = e.get("diverged")
    last = ([num(e.get("time_per_epoch_ms"), ".3f"), num(e.get("final_heading_sigma_deg"),
                                                            ".3f")] if online else
            [num(e.get("time_s"), ".2f"), num(e.get("isam2_time_over_filter_time"), ".1f")])
    return [name, rank, num(e.get("landmark_dist_to_ref_median_m"), ".3f"),
            num(e.get("landmark_dist_to_ref_max_m"), ".3f"),
            num(e.get("landmark_dist_to_ref_aligned_median_m"), ".3f"),
            num(e.get("map_rotation_to_ref_deg"), "+.2f"),
            num(e.get("final_pose_dist_to_ref_m"), ".3f"),
            num(e.get("pose_rmse_to_ref_m"), ".3f"), *last,
            MISSING if diverged is None else ("yes" if diverged else "no")]


TO_ONLINE_COLUMNS = ("pose RMSE to isam2 (m)", "heading RMSE to isam2 (deg)")
"""The report's columns before ``diverged`` with the online row: each filter's difference
to the online row over their epochs."""


def _to_online(rows: list[list[str]], summary: dict[str, Any]) -> list[list[str]]:
    """``rows`` (in :func:`estimator_entries` order) with :data:`TO_ONLINE_COLUMNS` before
    their last cell (``diverged``)."""
    return [[*r[:-1], num(e.get("pose_rmse_to_online_m"), ".3f"),
             num(e.get("heading_rmse_to_online_deg"), ".3f"), r[-1]]
            for r, (_, e) in zip(rows, estimator_entries(summary))]


def log_columns(summary: dict[str, Any]) -> tuple[str, ...]:
    """:data:`ONLINE_LOG_COLUMNS` when the run has the online row, else :data:`LOG_COLUMNS`."""
    return ONLINE_LOG_COLUMNS if summary.get("online") else LOG_COLUMNS


def log_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter, the online row, the odometry and the smoother (distances are
    to the smoother; the rank is the filters' by position difference to the smoother)."""
    rank = rank_column(summary, "position").cell
    online = bool(summary.get("online"))
    return [_row(name, e, rank(name, e), online) for name, e in estimator_entries(summary)]


def log_head(summary: dict[str, Any]) -> str:
    """The log's size and the smoother's objective and times, in one sentence."""
    g = (summary.get("reference") or {}).get(REFERENCE) or {}
    head = (f"{summary.get('log', '?')}: {summary.get('poses', '?')} poses, "
            f"{summary.get('landmarks', '?')} landmarks, {summary.get('observations', '?')} "
            f"observations, mode {summary.get('mode', '?')}.")
    if "objective" in g:
        head += (f" Smoother ½χ² {num(g.get('objective_isam2'), '.1f')} (iSAM2) -> "
                 f"{num(g.get('objective'), '.1f')} (+LM), iSAM2 "
                 f"{num(g.get('time_isam2_s'), '.1f')} s + LM {num(g.get('time_lm_s'), '.1f')} s.")
    return head


def log_table(summary: dict[str, Any]) -> str:
    """The compact terminal table of a recorded-log run (≤ 100 columns), with the log's
    description above and the failure reasons below."""
    notes = [*failure_notes(summary),
             "Distances are to the smoother's estimate; aligned: after the best rigid "
             "rotation + translation of the filter's map. Figures: report.html"]
    return "\n".join([wrap(log_head(summary)), "",
                      plain_table(log_columns(summary), log_rows(summary)),
                      *(wrap(n) for n in notes), "", decision_text(summary)])


HOW_TO_READ = (
    "A recorded log has no ground truth: each filter is compared with the GTSAM smoother "
    "(iSAM2 pose by pose, then a batch Levenberg-Marquardt polish) on the very same "
    "measurements. `lm dist` is the distance of each final landmark to the smoother's "
    "(median, max); `aligned` the same after the best rigid rotation + translation of the "
    "whole filter map (a map rotated as a whole is a heading error, what remains is "
    "distortion); `map rot.` that rotation; `final pose` the distance between the final "
    "poses; `pose RMSE` the position difference to the smoother over the filter's epochs; "
    "`iSAM2 / filter` the smoother's iSAM2 time over the filter's. With `--online` the "
    "row `isam2` is iSAM2's current pose and marginal after each filter epoch (the online "
    "optimum: the same records up to that pose), scored like a filter and not ranked; "
    "the table then shows each row's time per epoch and its own heading σ at the last "
    "epoch (the smoother's: its marginal at the last pose), and the report each filter's "
    "position and heading RMS difference to `isam2` over their epochs. The ranking "
    "orders the "
    "filters by their mean squared position (and heading) difference to the smoother over "
    "their epochs; a log is one run, so no difference can be called significant. The "
    "filters' own "
    "consistency can only be checked on their innovations (NIS, map_state.png).")


def _sections(summary: dict[str, Any]) -> list[Section]:
    head, *rest = decision_sections(summary) or [None]
    columns, rows = log_columns(summary), log_rows(summary)
    if summary.get("online"):
        columns, rows = (*columns[:-1], *TO_ONLINE_COLUMNS, columns[-1]), _to_online(rows,
                                                                                   summary)
    return [s for s in (head, Section("Results", columns, rows, log_head(summary)), *rest,
                        Section("How to read this", text=HOW_TO_READ)) if s is not None]


def _tracks(result: CampaignResult) -> dict:
    return result.outcomes[0].tracks if result.outcomes else {}


def _has_cov(tr) -> bool:
    return bool(np.any(np.isfinite(np.asarray(tr.pose_cov, dtype=float))))


def _rows(tr) -> np.ndarray:
    """The poses the TUM file holds (finite pose and index), as in :func:`tum_text`."""
    return np.all(np.isfinite(tr.poses), axis=1) & np.isfinite(np.asarray(tr.steps, float))


COV_NOTE = ("t (the pose index), then the 3 x 3 covariance of [x, y, heading] row-major "
            "(m², m·rad, rad²)")


def write_log_tum(result: CampaignResult, out_dir: Path) -> list[str]:
    """``<name>.tum`` for every estimator of the run (the time column is the pose index),
    and ``<name>.cov.txt`` beside it for those with a pose covariance (the filters and the
    online row; one line per pose of the TUM file)."""
    def text(name: str, tr) -> str:
        steps = np.asarray(tr.steps, dtype=float)
        n = int(np.sum(_rows(tr)))
        which = ("every pose of the chain" if name in (REFERENCE, "odometry") else
                 "the filter's epochs: the poses with sightings, the last pose, and one every "
                 f"{DEFAULT_MAX_EPOCH_STEPS} odometry steps between")
        return tum_text(steps, tr.poses,
                        f"{result.summary.get('log', '')}: {name}; time column = pose index "
                        "along the odometry chain (the log has no time stamps); t x y z qx "
                        f"qy qz qw\n{n} poses: {which}")

    tracks = _tracks(result)
    written = write_tum(Path(out_dir), ((n, text(n, tr)) for n, tr in tracks.items()))
    for n, tr in tracks.items():
        if _has_cov(tr):
            ok = _rows(tr)
            written.append(tum.write_cov(
                Path(out_dir), n, np.asarray(tr.steps, float)[ok], np.asarray(tr.pose_cov)[ok],
                f"{result.summary.get('log', '')}: {n}: covariance per pose of {n}.tum; "
                f"{COV_NOTE}"))
    return written


def log_links(result: CampaignResult) -> list[Link]:
    """The files :func:`write_log_tum` writes."""
    out: list[Link] = []
    for n, tr in _tracks(result).items():
        out.append((f"{n}.tum", f"{n}'s trajectory (TUM; time = pose index)"))
        if _has_cov(tr):
            out.append((f"{n}.cov.txt", f"its covariance per pose ({n}.tum's rows)"))
    return out


REPORT = KindReport("recorded-log run", _sections,
                    Deferred("slam.kinds.recorded.figures:figures"), log_table,
                    write_log_tum, log_links)
"""The recorded-log kind's report."""
