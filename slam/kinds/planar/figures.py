"""The planar report's figures (:data:`~slam.kinds.planar.report.REPORT` names this module
lazily, so a run without figures never imports matplotlib): pose errors, error against
predicted σ, consistency, the map over time and the differences between filters; the map
figure itself is :mod:`slam.kinds.planar.map_figure`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from slam.kinds.planar.map_figure import plot_map
from slam.render.consistency import NeesSpec, consistency_figure
from slam.render.figures import (
    COINCIDE,
    FigureSpec,
    default_colours,
    differences_figure,
    error_grid_figure,
    figure_table,
    map_figure,
    quoted_position_range,
    rmse_sigma_figure,
)
from slam.render.palette import filter_names
from slam.render.series import Component
from slam.results import REFERENCE, CampaignResult

DEG = 180.0 / math.pi


def _comp(label: str, unit: str, col: int, scale: float = 1.0) -> Component:
    return Component(label, unit, lambda s: s.err[:, col] * scale,
                     lambda s: s.sigma[:, col] * scale, "position" if col < 2 else "")


def _track(label: str, col: int) -> Component:
    return Component(label, "m", lambda s: s.err_track[:, col] if s.err_track is not None
                     else None,
                     lambda s: s.sig_track[:, col] if s.sig_track is not None else None)


X, Y, HEADING = _comp("x", "m", 0), _comp("y", "m", 1), _comp("heading", "deg", 2, DEG)
HORIZONTAL = Component("horizontal", "m", lambda s: np.hypot(s.err[:, 0], s.err[:, 1]),
                       lambda s: np.hypot(s.sigma[:, 0], s.sigma[:, 1]), "position")
POSE_ROWS = [[X, Y, HEADING], [_track("along-track", 0), _track("cross-track", 1),
                               HORIZONTAL]]

_ERRORS_XY = error_grid_figure([X, Y, HEADING], "vehicle pose error (run 0 with its ±2σ; "
                               "Monte Carlo envelope)", groups=((0, 1), (2,)),
                               paper=quoted_position_range)


ONLINE_COLOURS = ("black", "0.35", "tab:purple", "tab:cyan", "tab:olive", "tab:gray")
"""The online rows' colours (iSAM2 first, then the fixed-lag smoothers)."""


def online_row_names(result: CampaignResult) -> list[str]:
    """The campaign's online rows (``isam2``, ``fls-<lag>s``), in summary order."""
    return list((result.summary.get("online") or {}).keys())


def with_online(result: CampaignResult) -> list[str]:
    """The filters, the online rows, then the smoother, as far as run 0 scored them."""
    scored = result.outcomes[0].scores
    names = [*filter_names(result), *online_row_names(result), REFERENCE]
    return [n for n in names if n in scored]


def online_colours(result: CampaignResult) -> dict[str, str]:
    """The default colours and one of :data:`ONLINE_COLOURS` per online row."""
    out = default_colours(result)
    for i, n in enumerate(online_row_names(result)):
        out[n] = ONLINE_COLOURS[i % len(ONLINE_COLOURS)]
    return out


def plot_errors_xy(result: CampaignResult, path: Path) -> None:
    """``errors_xy.png``: one row per filter, x / y error (m) and heading error (deg) vs
    time (:func:`~slam.render.figures.error_grid_figure`)."""
    _ERRORS_XY(result, path)


def figure_specs() -> list[FigureSpec]:
    """The planar report's figures (built at call time, so a replaced function is used)."""
    return [
        FigureSpec("map.png", "Run 0: true landmarks, waypoints, true / filtered / smoothed / "
                   "dead-reckoned paths and the final landmark estimates with 2σ ellipses.",
                   plot_map),
        FigureSpec("errors_xy.png", "x and y error (m) and heading error (deg, wrapped) vs "
                   "time, one row per filter: run 0 with its ±2σ band, the Monte Carlo "
                   "envelope (min/max over all runs), the smoother's run 0 and the paper's "
                   "range (dashed) where the paper quotes one.", plot_errors_xy),
        FigureSpec("rmse_sigma.png", "Monte Carlo RMSE (solid) vs the RMS of each "
                   "estimator's own σ (dashed) per epoch: x, y, heading; along-track and "
                   "cross-track (in the true heading's frame) and horizontal position. A "
                   "consistent filter's two curves coincide. Odometry is left out (see the "
                   "table). " + COINCIDE,
                   rmse_sigma_figure(POSE_ROWS, "error vs predicted σ", note_coinciding=True)),
        FigureSpec("nees.png", "Pose NEES / 3 and NIS / dof per epoch (run averages) "
                   "against their 95 % bands (dashed: constant band; grey: a band that "
                   "varies with the number of updates), with the fraction of epochs inside; "
                   "right: histograms of the per-run time averages (1 = consistent). The "
                   "online rows (isam2: the online optimum; fls-<lag>s: fixed-lag "
                   "smoothers), when run, are drawn beside the filters.",
                   consistency_figure([NeesSpec("pose NEES / 3", 3, lambda s: s.nees)],
                                      estimators=with_online, colours=online_colours)),
        FigureSpec("landmarks.png", "The filters' maps per epoch (run averages): RMSE and "
                   "NEES / 2 of the landmarks in the state (against the band), landmarks "
                   "in the state, trace of the map covariance; the smoother's final "
                   "landmark RMSE dashed. " + COINCIDE, map_figure("the map over time")),
        FigureSpec("differences.png", "Each filter minus the base filter (SRCKF) on the "
                   "same runs (truth cancels): RMS over runs per epoch, with the base "
                   "filter's RMS σ (dotted) for scale.",
                   differences_figure([[X, Y, HEADING]],
                                      "each filter minus {base} on the same data")),
    ]


def figures() -> dict[str, tuple[Callable[[CampaignResult, Path], None], str]]:
    """File name -> (function drawing it, caption), for
    :class:`~slam.render.document.KindReport` (named lazily by the report)."""
    return figure_table(figure_specs())
