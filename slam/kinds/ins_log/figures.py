"""Figures of an IMU + GNSS log run.

    trajectory.png  the GNSS fixes (used, withheld, dropped in outages) and every
                    estimator's positions at the fix epochs, east/north
    heldout.png     each estimator's error at the withheld fixes against time, with the
                    filters' own ±2σ (3-D, from the position covariance plus the fix σ)
"""

from __future__ import annotations

import numpy as np

from slam.kinds.ins_log.run import DROPPED, USED, WITHHELD, fix_roles
from slam.render.figures import PANEL_WIDTH, Figure, FigureSpec, default_colours, figure_table
from slam.render.plotting import REFERENCE_COLOUR, inch_layout, plt, save, titled
from slam.results import REFERENCE, CampaignResult


def _tracks(result: CampaignResult) -> dict:
    return result.outcomes[0].tracks if result.outcomes else {}


def _colour(result: CampaignResult, name: str) -> str:
    col = default_colours(result)
    return col.get(name, REFERENCE_COLOUR if name == REFERENCE else "0.45")


def plot_trajectory(result: CampaignResult, path) -> None:
    log = result.world.log
    roles = fix_roles(log, result.world.scoring)
    fig, ax = plt.subplots(figsize=(PANEL_WIDTH, 8.0))
    inch_layout(fig, 1, 1, left=0.75, top=0.3, bottom=0.5)
    for role, mark, label in ((USED, ".", "GNSS fix (used)"), (WITHHELD, "x", "withheld fix"),
                              (DROPPED, "s", "fix dropped (outage)")):
        sel = roles == role
        if sel.any():
            ax.plot(log.fix_p[sel, 0], log.fix_p[sel, 1], mark, color="0.55", ms=4,
                    mfc="none" if role == DROPPED else None, label=label)
    for name, tr in _tracks(result).items():
        ok = np.all(np.isfinite(tr.p), axis=1)
        ax.plot(tr.p[ok, 0], tr.p[ok, 1], lw=0.9, color=_colour(result, name), label=name,
                ls="--" if name == REFERENCE else "-")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m, the log's local frame)")
    ax.set_ylabel("north (m)")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.legend(fontsize=9, loc="best")
    ax.set_title(titled(result, "positions at the fix epochs"), fontsize=11)
    save(fig, path)


def plot_heldout(result: CampaignResult, path) -> None:
    s = result.summary
    log = result.world.log
    fig, ax = plt.subplots(figsize=(PANEL_WIDTH, 4.5))
    inch_layout(fig, 1, 1, left=0.75, top=0.3, bottom=0.55)
    tracks = _tracks(result)
    t0 = log.t[0]
    for group in ("filters", "reference"):
        for name, e in (s.get(group) or {}).items():
            h = e.get("heldout") or {}
            if not h.get("fix"):
                continue
            idx = np.asarray(h["fix"])
            err = np.array([np.nan if x is None else x for x in h["error_m"]])
            ax.plot(log.fix_t[idx] - t0, err, ".-", lw=0.7, ms=3, color=_colour(result, name),
                    label=name)
            tr = tracks.get(name)
            if tr is not None and group == "filters":
                a = log.n_fixes - tr.p.shape[0]
                R = log.fix_sp[idx] ** 2
                sig = np.sqrt(np.trace(tr.P[idx - a], axis1=1, axis2=2) + R.sum(axis=1))
                ax.plot(log.fix_t[idx] - t0, 2 * sig, ":", lw=0.8, color=_colour(result, name))
    ax.set_xlabel("time from the first IMU reading (s)")
    ax.set_ylabel("error at withheld fixes (m)")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.plot([], [], ":", color="0.3", label="filter's 2σ (dotted)")
    ax.legend(fontsize=8, loc="upper left", ncol=3)
    ax.set_title(titled(result, "held-out fix errors"), fontsize=11)
    save(fig, path)


def figures() -> dict[str, tuple[Figure, str]]:
    return figure_table([
        FigureSpec("trajectory.png", "GNSS fixes and each estimator's positions (east/north)",
                   plot_trajectory),
        FigureSpec("heldout.png", "error at the withheld fixes, with the filters' 2σ",
                   plot_heldout)])
