"""Figures of a ``fixed-wing`` campaign ([Fixed-wing EA-UKF] Fig. 2-5 re-drawn from our runs).

    attitude_errors.png  roll / pitch / heading error vs time, a row per estimator: run 0,
                         its ±2σ, the Monte Carlo envelope; turn epochs shaded
    nav_errors.png       east / north position and velocity error vs time (the paper's
                         Fig. 3-4) for the INS filters and the smoother
    nees.png             run-averaged NEES / dof vs time against its 95 % band
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from slam.render.document import Figure
from slam.render.figures import FigureSpec, figure_table
from slam.render.plotting import estimator_colours, inch_layout, plt, save, titled
from slam.render.series import good_scores
from slam.results import REFERENCE, CampaignResult
from slam.scoring import anees_band

DEG = 180.0 / math.pi
TURN = {"color": "0.88", "lw": 0, "zorder": 0}


def _names(result: CampaignResult, want: Callable[[str], bool] = lambda n: True) -> list[str]:
    first = result.outcomes[0].scores
    names = [*(result.summary.get("filters") or {}), REFERENCE]
    return [n for n in names if n in first and want(n)]


def _shade(ax: Any, t: np.ndarray, turn: np.ndarray) -> None:
    if turn.any():
        ax.fill_between(t, 0, 1, where=turn, transform=ax.get_xaxis_transform(), **TURN)


def _panel(ax: Any, good: list[Any], get: Callable[[Any], np.ndarray],
           sig: Callable[[Any], np.ndarray] | None, colour: str) -> None:
    """Run 0 (or the first good run), its ±2σ and the Monte Carlo envelope."""
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
    ax.grid(True, lw=0.3, alpha=0.5)


def _grid_figure(result: CampaignResult, path: Path, names: list[str],
                 cols: list[tuple[str, Callable, Callable | None]], what: str) -> None:
    colours = estimator_colours(names)
    fig, axes = plt.subplots(max(len(names), 1), len(cols), sharex=True, squeeze=False,
                             figsize=(12.0, 1.0 + 1.6 * max(len(names), 1)))
    for i, name in enumerate(names):
        good = good_scores(result, name)
        for j, (label, get, sig) in enumerate(cols):
            ax = axes[i, j]
            if good:
                _panel(ax, good, get, sig, colours.get(name, "k"))
            ax.set_title(f"{name}: {label}", fontsize=8)
            ax.tick_params(labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)", fontsize=8)
    fig.suptitle(titled(result, what), fontsize=10)
    inch_layout(fig, *axes.shape, left=0.7, top=0.55, bottom=0.45, wgap=0.7, hgap=0.4)
    save(fig, path)


def _att(i: int) -> tuple[Callable, Callable]:
    return (lambda s: s.err_att[:, i] * DEG), (lambda s: s.sig_att[:, i] * DEG)


def plot_attitude(result: CampaignResult, path: Path) -> None:
    """``attitude_errors.png`` (module docstring)."""
    cols = [(f"{a} error (°)", *_att(i)) for i, a in enumerate(("roll", "pitch", "heading"))]
    _grid_figure(result, path, _names(result), cols,
                 "attitude errors (grey: turns; band: Monte Carlo min-max; dotted: ±2σ)")


def plot_nav(result: CampaignResult, path: Path) -> None:
    """``nav_errors.png`` (module docstring)."""
    cols = [("east position error (m)", lambda s: s.err_pos[:, 0], None),
            ("north position error (m)", lambda s: s.err_pos[:, 1], None),
            ("east velocity error (m/s)", lambda s: s.err_vel[:, 0], None),
            ("north velocity error (m/s)", lambda s: s.err_vel[:, 1], None)]
    names = _names(result, lambda n: not n.startswith("ea-"))
    _grid_figure(result, path, names, cols, "position and velocity errors (paper's Fig. 3-4)")


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
                   "the Monte Carlo min-max envelope; turn epochs shaded grey.", plot_attitude),
        FigureSpec("nav_errors.png", "East/north position and velocity errors of the INS "
                   "filters and the smoother (the paper's Fig. 3-4).", plot_nav),
        FigureSpec("nees.png", "Run-averaged NEES / dof per epoch against its two-sided 95 % "
                   "band.", plot_nees),
    ])
