"""Figures of a ``fixed-wing`` campaign ([Fixed-wing EA-UKF] Fig. 2-5 re-drawn from our runs).

    attitude_errors.png  roll / pitch / heading error vs time, a row per estimator: run 0,
                         its ±2σ, the Monte Carlo envelope, the paper's mean heading
                         errors; turn epochs shaded
    nav_errors.png       east / north position and velocity error vs time (the paper's
                         Fig. 3-4) for the INS filters and the smoother: run 0, its ±2σ,
                         the envelope and the paper's mean errors (Table 1)

Rows whose run-0 curves coincide are named under each figure with their largest
difference (:func:`slam.render.series.coincidence_note`).
    nees.png             run-averaged NEES / dof vs time against its 95 % band
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from slam.render.document import Figure
from slam.render.figures import FigureSpec, figure_table
from slam.render.plotting import (
    Line2D,
    Patch,
    bottom_legend,
    estimator_colours,
    inch_layout,
    plt,
    save,
    titled,
)
from slam.render.series import coincidence_note, good_scores
from slam.results import REFERENCE, CampaignResult
from slam.scoring import anees_band

DEG = 180.0 / math.pi
TURN = {"color": "0.88", "lw": 0, "zorder": 0}
PAPER = {"ckf": {"ls": "--", "lw": 1.0, "color": "0.2"},
         "ukf": {"ls": "-.", "lw": 1.0, "color": "0.45"}}
"""How the paper's Table 1 mean errors are drawn: its CKF and its UKF row."""
Column = tuple[str, Callable, "Callable | None", "str | None"]
"""(title, error of a score, its σ or None, the paper's Table 1 key or None)."""


def _legend(paper: bool) -> list[Any]:
    out = [Line2D([], [], color="0.3", lw=0.7, label="run 0 error (row colour)"),
           Line2D([], [], color="k", lw=0.5, ls=":", label="run 0 ±2σ"),
           Patch(fc="0.3", alpha=0.18, label="Monte Carlo min-max (row colour)"),
           Patch(fc=TURN["color"], label="turn (heading rate above the world's threshold)")]
    if paper:
        out += [Line2D([], [], **PAPER["ckf"], label="paper's CKF mean |error| (Table 1)"),
                Line2D([], [], **PAPER["ukf"], label="paper's UKF mean |error| (Table 1)")]
    return out


def _names(result: CampaignResult, want: Callable[[str], bool] = lambda n: True) -> list[str]:
    first = result.outcomes[0].scores
    names = [*(result.summary.get("filters") or {}), REFERENCE]
    return [n for n in names if n in first and want(n)]


def _shade(ax: Any, t: np.ndarray, turn: np.ndarray) -> None:
    if turn.any():
        ax.fill_between(t, 0, 1, where=turn, transform=ax.get_xaxis_transform(), **TURN)


def _panel(ax: Any, good: list[Any], get: Callable[[Any], np.ndarray],
           sig: Callable[[Any], np.ndarray] | None, colour: str,
           paper: dict[str, float] | None = None) -> None:
    """Run 0 (or the first good run), its ±2σ, the Monte Carlo envelope and ± the
    paper's mean errors (``paper``: filter -> value)."""
    s = good[0]
    t = s.times
    _shade(ax, t, s.turn)
    stack = np.stack([get(g) for g in good])
    with np.errstate(invalid="ignore"):
        ax.fill_between(t, np.nanmin(stack, axis=0), np.nanmax(stack, axis=0), color=colour,
                        alpha=0.18, lw=0)
    ax.plot(t, get(s), color=colour, lw=0.7)
    if sig is not None:
        ax.plot(t, 2 * sig(s), color="k", lw=0.5, ls=":")
        ax.plot(t, -2 * sig(s), color="k", lw=0.5, ls=":")
    for name, v in (paper or {}).items():
        for sign in (1.0, -1.0):
            ax.axhline(sign * v, **PAPER[name])
    ax.grid(True, lw=0.3, alpha=0.5)


def _paper_values(result: CampaignResult, key: str | None) -> dict[str, float]:
    table = (result.summary.get("paper") or {}).get("table1") or {}
    out = {n: (table.get(n) or {}).get(key) for n in PAPER} if key else {}
    return {n: float(v) for n, v in out.items() if isinstance(v, int | float)}


def _grid_figure(result: CampaignResult, path: Path, names: list[str], cols: list[Column],
                 what: str) -> None:
    colours = estimator_colours(names)
    fig, axes = plt.subplots(max(len(names), 1), len(cols), sharex=True, squeeze=False,
                             figsize=(12.0, 1.6 + 1.6 * max(len(names), 1)))
    short = {c[0]: c[0].rpartition(" (")[0] for c in cols}
    run0: dict[str, dict[str, np.ndarray | None]] = {short[c[0]]: {} for c in cols}
    drew_paper = False
    for i, name in enumerate(names):
        good = good_scores(result, name)
        for j, (label, get, sig, key) in enumerate(cols):
            ax = axes[i, j]
            paper = _paper_values(result, key)
            if good:
                _panel(ax, good, get, sig, colours.get(name, "k"), paper)
                run0[short[label]][name] = get(good[0])
                drew_paper |= bool(paper)
            ax.set_title(f"{name}: {label}", fontsize=8)
            ax.tick_params(labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)", fontsize=8)
    fig.suptitle(titled(result, what), fontsize=10)
    bottom_legend(fig, _legend(drew_paper), ncols=3)
    units = {short[c[0]]: c[0].rpartition("(")[2].rstrip(")") for c in cols}
    lines = textwrap.wrap(coincidence_note(run0, units, "run 0's curves"), 170)
    if lines:
        fig.text(0.5, 0.5 / fig.get_size_inches()[1], "\n".join(lines), ha="center",
                 va="bottom", fontsize=7)
    inch_layout(fig, *axes.shape, left=0.7, top=0.8, bottom=0.95 + 0.14 * len(lines),
                wgap=0.7, hgap=0.4)
    save(fig, path)


def _att(i: int) -> tuple[Callable, Callable]:
    return (lambda s: s.err_att[:, i] * DEG), (lambda s: s.sig_att[:, i] * DEG)


def plot_attitude(result: CampaignResult, path: Path) -> None:
    """``attitude_errors.png`` (module docstring)."""
    cols = [(f"{a} error (°)", *_att(i), "heading_deg" if a == "heading" else None)
            for i, a in enumerate(("roll", "pitch", "heading"))]
    _grid_figure(result, path, _names(result), cols,
                 "attitude errors (grey: turns; band: Monte Carlo min-max; dotted: ±2σ)")


def plot_nav(result: CampaignResult, path: Path) -> None:
    """``nav_errors.png`` (module docstring)."""
    def pos(i: int) -> tuple[Callable, Callable]:
        return (lambda s: s.err_pos[:, i]), (lambda s: s.sig_pos[:, i])

    def vel(i: int) -> tuple[Callable, Callable]:
        return (lambda s: s.err_vel[:, i]), (lambda s: s.sig_vel[:, i])

    cols = [("east position error (m)", *pos(0), "longitude_m"),
            ("north position error (m)", *pos(1), "latitude_m"),
            ("east velocity error (m/s)", *vel(0), "east_velocity_mps"),
            ("north velocity error (m/s)", *vel(1), "north_velocity_mps")]
    names = _names(result, lambda n: not n.startswith("ea-"))
    _grid_figure(result, path, names, cols, "position and velocity errors (paper's Fig. 3-4; "
                 "grey: turns; band: Monte Carlo min-max; dotted: ±2σ)")


def plot_nees(result: CampaignResult, path: Path) -> None:
    """``nees.png`` (module docstring)."""
    names = _names(result)
    colours = estimator_colours(names)
    fig, axes = plt.subplots(1, 2, figsize=(12.0, 3.8), squeeze=False)
    for name in names:
        good = good_scores(result, name)
        if not good:
            continue
        ax = axes[0, 0 if name.startswith("ea-") else 1]
        dof = good[0].nees_dof
        avg = np.nanmean(np.stack([g.nees for g in good]), axis=0) / dof
        ax.semilogy(good[0].times, avg, color=colours.get(name, "k"), lw=0.8, label=name)
        lo, hi = anees_band(len(good), dof)
        ax.axhline(lo, color="k", lw=0.5, ls="--")
        ax.axhline(hi, color="k", lw=0.5, ls="--")
    for ax, what in zip(axes[0], ("EA filters: 3-dof Euler NEES / 3",
                                  "INS filters and smoother: 9-dof [p, v, θ] NEES / 9")):
        ax.set_title(what, fontsize=9)
        ax.set_xlabel("time (s)", fontsize=8)
        ax.set_ylabel("NEES / dof", fontsize=8)
        ax.grid(True, lw=0.3, alpha=0.5)
        if ax.lines:
            ax.legend(fontsize=7)
    fig.suptitle(titled(result, "run-averaged NEES / dof and its 95 % band (dashed)"),
                 fontsize=10)
    inch_layout(fig, 1, 2, left=0.8, top=0.6, bottom=0.5, wgap=0.95)
    save(fig, path)


def figures() -> dict[str, tuple[Figure, str]]:
    """File name -> (function drawing it, caption)."""
    return figure_table([
        FigureSpec("attitude_errors.png", "Roll, pitch and heading error vs time per "
                   "estimator (the paper's Fig. 2 and 5): the first run, its ±2σ (dotted) and "
                   "the Monte Carlo min-max envelope; turn epochs shaded grey; on the heading "
                   "panels ± the paper's mean heading errors (Table 1: CKF dashed, UKF "
                   "dash-dotted). Rows whose run-0 curves coincide (largest difference below "
                   "1 % of the curve) are named under the figure with their largest "
                   "difference.", plot_attitude),
        FigureSpec("nav_errors.png", "East/north position and velocity errors of the INS "
                   "filters and the smoother (the paper's Fig. 3-4): the first run, its ±2σ "
                   "(dotted), the Monte Carlo min-max envelope, turn epochs shaded grey, and "
                   "± the paper's mean errors (Table 1, 4.0-10.3 m, 0.8-4.8 m/s: CKF dashed, "
                   "UKF dash-dotted). Rows whose run-0 curves coincide are named under the "
                   "figure with their largest difference.", plot_nav),
        FigureSpec("nees.png", "Run-averaged NEES / dof per epoch against its two-sided 95 % "
                   "band.", plot_nees),
    ])
