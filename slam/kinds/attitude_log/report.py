"""Report of a recorded attitude log (``slam run --log eqf``): the filters and the GTSAM
AHRS smoother against the log's truth and the filters against the smoother, the filters'
settings and initial belief, and the figures (errors with their own σ, NEES and NIS
against their bands)."""

from __future__ import annotations

from typing import Any

from slam.render import tum
from slam.render.decision import decision_sections, decision_text, rank_column
from slam.render.document import KindReport, Section
from slam.render.tables import MISSING, anees_cell, interval, num, plain_table
from slam.results import REFERENCE

HEADER = ("estimator", "rank", "att RMS (deg)", "after 10 s (deg)", "final (deg)",
          "bias RMS (deg/s)",
          "vs smoother after 10 s (deg)", "ANEES [95 % band]", "verdict", "NIS/dof [95 % interval]",
          "CPU (s)", "diverged")


def _row(name: str, e: dict[str, Any], rank: str) -> list[str]:
    if e.get("diverged"):
        return [name, rank, *([MISSING] * 9), f"yes: {e.get('failure')}"]
    nis = num(e.get("nis_per_dof"), ".2f")
    if nis != MISSING:
        nis = f"{nis} {interval(e.get('nis_bounds_95'), '.2f')}"
    return [name, rank, num(e.get("att_rmse_deg"), ".3f"),
            num(e.get("att_rmse_after_10s_deg"), ".3f"),
            num(e.get("att_final_deg"), ".3f"), num(e.get("bias_rmse_deg_s"), ".4f"),
            num(e.get("att_rmse_to_smoother_after_10s_deg"), ".3f"), anees_cell(e),
            e.get("consistency", MISSING), nis, num(e.get("cpu_s"), ".2f"), "no"]


def rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per filter (with its rank on the whole-log attitude error), then the
    smoother."""
    rank = rank_column(summary, "attitude").cell
    return [*(_row(n, e, rank(n, e)) for n, e in summary["filters"].items()),
            *(_row(f"{n} (smoother)", e, MISSING) for n, e in summary["reference"].items())]


def settings_rows(summary: dict[str, Any]) -> list[list[str]]:
    """Each filter's settings, the initial belief and the gyro noise read from the log."""
    b = summary["initial_belief"]
    out = [[n, e.get("settings_text") or "none"] for n, e in summary["filters"].items()]
    out.append(["initial belief", f"{b['attitude']} attitude, zero bias; P0 = diag("
                f"{b['attitude_var_rad2']:g} I3 rad², {b['bias_var_rad2_s2']:g} I3 rad²/s²)"])
    out.append(["gyro noise (from the log)",
                f"ARW {', '.join(f'{v:.3g}' for v in summary['gyro_arw_rad_sqrt_s'])} rad/√s; "
                f"bias RW {', '.join(f'{v:.3g}' for v in summary['gyro_bias_rw_rad_s_sqrt_s'])}"
                " rad/s/√s"])
    return out


def sections(summary: dict[str, Any]) -> list[Section]:
    ref = summary["reference"].get(REFERENCE, {})
    smoother = ("" if ref.get("diverged") else
                f" The smoother solved in {num(ref.get('time_s'), '.2f')} s, its marginals "
                f"in {num(ref.get('marginals_time_s'), '.2f')} s.")
    text = (f"{summary['log']}: {summary['rows']} gyro rows over "
            f"{summary['duration_s']:.1f} s, {summary['sensors']} direction sensors "
            f"({', '.join(map(str, summary['readings_per_sensor']))} readings), "
            f"{summary['epochs']} filter epochs. Attitude errors are |Log(q̂* ⊗ q)| at the "
            f"epochs against the log's truth; 'vs smoother' is the same against the GTSAM "
            f"AHRS smoother. ANEES: 6-dof NEES over the epochs with the one-run 95 % band; "
            f"NIS: {summary['nis_dof_note']}.{smoother}")
    head, *rest = decision_sections(summary) or [None]
    return [s for s in (head, Section("Results", HEADER, rows(summary), text), *rest,
                        Section("Settings", ("item", "value"), settings_rows(summary),
                                key_value=True)) if s is not None]


def figures() -> dict[str, tuple[Any, str]]:
    from slam.kinds.attitude_log.run import DEG
    from slam.render.consistency import NeesSpec, consistency_figure
    from slam.render.figures import FigureSpec, figure_table, rmse_sigma_figure
    from slam.render.series import Component, column

    att = [Component(a, "deg", column("err", i, 1 / DEG), column("sigma", i, 1 / DEG),
                     "attitude") for i, a in enumerate("xyz")]
    bias = [Component(a, "deg/s", column("err", 3 + i, 1 / DEG),
                      column("sigma", 3 + i, 1 / DEG), "bias") for i, a in enumerate("xyz")]
    return figure_table([
        FigureSpec("errors.png", "Attitude (body frame) and bias errors against the log's "
                   "truth (solid) and each estimator's own σ (dashed), log scale.",
                   rmse_sigma_figure([att, bias], "errors and own σ", log=True)),
        FigureSpec("consistency.png", "6-dof NEES and the filters' NIS per epoch against "
                   "their 95 % bands.", consistency_figure([NeesSpec("NEES / 6", 6,
                                                                     lambda s: s.nees)]))])


def _quats(o, name: str):
    return o.truth[:, :4] if name == "truth" else o.tracks[name].quats


def _covs(o, name: str):
    return None if name == "truth" else o.tracks[name].cov


write_tum_files, tum_links = tum.attitude_files(
    _quats, _covs, "poses at the filter epochs (the first row, every row with a direction "
    "reading, the last row)")
"""TUM files (zero position) and attitude covariance sidecars of the tracked runs, and the
report's entries for them (:func:`slam.render.tum.attitude_files`)."""


REPORT = KindReport(what="recorded attitude log", sections=sections, figures=figures,
                    text_table=lambda s: "\n".join([plain_table(HEADER, rows(s)), "",
                                                    decision_text(s)]),
                    extra_files=write_tum_files, links=tum_links)
