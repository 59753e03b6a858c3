"""Report of a recorded-log run: the table of filters against the smoother."""

from __future__ import annotations

from typing import Any

from slam.render.document import KindReport, Section
from slam.render.tables import plain_table

LOG_COLUMNS = ("estimator", "lm dist median (m)", "lm dist max (m)", "aligned median (m)",
               "map rotation (deg)", "final pose dist (m)", "time (s)", "iSAM2 time / time",
               "diverged")


def log_table(summary: dict[str, Any]) -> str:
    """The plain-text results table of a recorded-log run (distances are to the smoother;
    "aligned" after the best rigid rotation + translation of the filter's map)."""
    def num(v: Any, fmt: str) -> str:
        return "—" if v is None else format(v, fmt)

    rows = []
    for name, e in summary["filters"].items():
        rows.append([name, num(e.get("landmark_dist_to_ref_median_m"), ".3f"),
                     num(e.get("landmark_dist_to_ref_max_m"), ".3f"),
                     num(e.get("landmark_dist_to_ref_aligned_median_m"), ".3f"),
                     num(e.get("map_rotation_to_ref_deg"), "+.2f"),
                     num(e.get("final_pose_dist_to_ref_m"), ".3f"), num(e.get("time_s"), ".2f"),
                     num(e.get("isam2_time_over_filter_time"), ".1f"),
                     "yes" if e.get("diverged") else "no"])
    o = summary["baselines"]["odometry"]
    rows.append(["odometry", "—", "—", "—", "—", num(o["final_pose_dist_to_ref_m"], ".3f"), "—",
                 "—", "—"])
    g = summary["reference"]["gtsam"]
    rows.append(["gtsam", "0", "0", "0", "0", "0", num(g["time_s"], ".2f"), "—", "—"])
    head = (f"{summary['log']}: {summary['poses']} poses, {summary['landmarks']} landmarks, "
            f"{summary['observations']} observations, mode {summary['mode']}; smoother "
            f"½χ² {g['objective_isam2']:.1f} (iSAM2) -> {g['objective']:.1f} (+LM), "
            f"iSAM2 {g['time_isam2_s']:.1f} s + LM {g['time_lm_s']:.1f} s")
    return head + "\n\n" + plain_table(LOG_COLUMNS, rows)


def _sections(summary: dict[str, Any]) -> list[Section]:
    return [Section("Results", text=log_table(summary))]


REPORT = KindReport("recorded-log run", _sections, dict, log_table)
"""The recorded-log kind's report."""
