"""Figure helpers shared by the kinds' reports: the Agg backend, resolution, colours,
saving, run 0's tracks, covariance ellipses, run averages, and the error-grid figure
(one row per filter, one column per error component)."""

from __future__ import annotations

import math
import textwrap
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the backend)
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Ellipse, Patch  # noqa: E402
from matplotlib.ticker import (  # noqa: E402
    FuncFormatter,
    LogLocator,
    MaxNLocator,
    NullFormatter,
)

from slam.render.palette import (  # noqa: E402, F401  (re-exported)
    BASELINE_COLOUR,
    EIGHT_COLOURS,
    FILTER_COLOURS,
    REFERENCE_COLOUR,
    estimator_colours,
    filter_colours,
    filter_names,
    run0,
    titled,
)
from slam.render.series import good_scores, n_epochs  # noqa: E402, F401  (re-exported)
from slam.results import Array, CampaignResult  # noqa: E402
from slam.scoring import pad_stack  # noqa: E402

DPI = 110
def save(fig: plt.Figure, path) -> None:
    """Save ``fig`` at :data:`DPI` and close it."""
    try:
        fig.savefig(path, dpi=DPI)
    finally:
        plt.close(fig)


def covariance_ellipse(mean: Array, cov: Array, n_sigma: float = 2.0, **kw) -> Ellipse | None:
    """The ``n_sigma`` ellipse of a 2-D Gaussian, or None if ``cov`` is unusable."""
    if not (np.all(np.isfinite(cov)) and np.all(np.isfinite(mean))):
        return None
    w, v = np.linalg.eigh(0.5 * (cov + cov.T))
    if w[0] < 0.0:
        return None
    angle = math.degrees(math.atan2(v[1, 1], v[0, 1]))
    return Ellipse(tuple(mean), 2 * n_sigma * math.sqrt(w[1]), 2 * n_sigma * math.sqrt(w[0]),
                   angle=angle, **kw)


def envelope(scores: list, values: Callable, length: int | None = None
             ) -> tuple[Array, Array] | None:
    """Monte Carlo envelope (per-epoch min and max over runs) of ``values(score)`` over
    ``length`` epochs (runs of other lengths padded with NaN or cut; default: the
    longest)."""
    if not scores:
        return None
    a = pad_stack([values(s) for s in scores], length)
    if not np.isfinite(a).any():
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # epochs with no value in any run
        return np.nanmin(a, axis=0), np.nanmax(a, axis=0)


def envelope_and_run0(result: CampaignResult, name: str, err: Callable,
                      sigma: Callable | None) -> tuple[tuple[Array, Array] | None,
                                                       tuple[Array, Array] | None]:
    """The Monte Carlo :func:`envelope` of ``err(scores)`` over the runs ``name`` did not
    diverge on, and run 0's ``(err, sigma)`` (None where run 0 has no scores of ``name``,
    diverged, or ``sigma`` is None)."""
    s0 = result.outcomes[0].scores.get(name)
    shown = None
    if s0 is not None and not s0.diverged and sigma is not None:
        shown = (err(s0), sigma(s0))
    return envelope(good_scores(result, name), err, n_epochs(result)), shown


def estimator_lines(axes: Sequence[plt.Axes], t: Array, names: Sequence[str],
                    colours: dict[str, str], series: Callable[[str], Array | None],
                    column: Callable[[str, Array, int], Array | None] | None = None,
                    style: Callable[[str], str] = lambda name: "-") -> None:
    """One line per estimator in ``names`` with a ``series(name)`` in every panel of
    ``axes``: panel ``col`` draws ``column(name, series, col)`` (default: column ``col``
    of a 2-d series, a 1-d one whole; None: not drawn).  The first estimator is drawn
    widest and each next one thinner, so coinciding estimators stay visible."""
    for k, name in enumerate(names):
        y = series(name)
        if y is None:
            continue
        lw = 0.9 + 1.6 * (len(names) - 1 - k) / max(len(names) - 1, 1)
        for col, ax in enumerate(axes):
            yc = (y if y.ndim == 1 else y[:, col]) if column is None else column(name, y, col)
            if yc is not None:
                ax.plot(t, yc, color=colours[name], lw=lw, ls=style(name), label=name)


def log_time_panels(fig: plt.Figure, axes: Sequence[plt.Axes], result: CampaignResult,
                    titles: Sequence[str], levels: Sequence[float | None], ylabel: str,
                    title: str, path, ncols: int) -> None:
    """Finish and save a row of log-scale panels vs time: panel titles, a dotted line at
    each panel's level (where it is a number), the first panel's lines as a bottom legend
    of at most ``ncols`` columns and the figure's ``title``."""
    for ax, what, level in zip(axes, titles, levels):
        ax.set_yscale("log")
        if isinstance(level, int | float):
            ax.axhline(level, color="0.3", ls=":", lw=1.0)
        ax.set_title(what, fontsize=10)
        ax.set_xlabel("time (s)")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    axes[0].set_ylabel(ylabel)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), ncols),
               fontsize=8, frameon=False)
    fig.suptitle(titled(result, title), fontsize=11)
    save(fig, path)


def nees_band_axes(ax: plt.Axes, result: CampaignResult, dof: int, what: str) -> None:
    """Finish a run-averaged NEES / ``dof`` panel: the 95 % band of the campaign's runs
    shaded, a log axis, labels, legend and the title ``what``."""
    from slam.scoring import anees_band

    lo, hi = anees_band(len(result.outcomes), dof)
    ax.axhspan(lo, hi, color="0.5", alpha=0.2, lw=0, label="95 % band")
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"run-averaged NEES / {dof}")
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.legend(fontsize=8, ncols=3, frameon=False)
    ax.set_title(titled(result, what), fontsize=11)


def run_average(series: list[Array], dof: float) -> Array:
    """Per-epoch mean over runs of ``series`` divided by ``dof``; NaN where no run has a
    positive value (a log axis drops them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # epochs with no value in any run
        mean = np.nanmean(np.stack(series), axis=0) / dof
    mean[~(mean > 0.0)] = np.nan
    return mean


# --------------------------------------------------------------------------- error grid

@dataclass(frozen=True)
class ErrorPanel:
    """What one panel of :func:`error_grid` shows, in the plotted unit: the Monte Carlo
    envelope, run 0's ``(error, σ)`` (or a ``note`` where run 0 has none), the
    smoother's run-0 error and the paper's range."""

    env: tuple[Array, Array] | None
    run0: tuple[Array, Array] | None = None
    note: str = ""
    reference: Array | None = None
    paper: Sequence[float] | None = None
    settle: int = 0
    """Epochs left out of the y range (a transient that would flatten the rest)."""
    limit: Sequence[float] | None = None
    """A theoretical limit (e.g. the level limit ∇/g), drawn dotted at these values."""

    def extent(self) -> list[float]:
        """The magnitudes the panel's y range must hold (not a diverged run's blow-up)."""
        env = None if self.env is None else np.abs(np.asarray(self.env)[:, self.settle:])
        out = [] if env is None or not np.isfinite(env).any() else [float(np.nanmax(env))]
        return (out + ([] if self.paper is None else [abs(v) for v in self.paper])
                + ([] if self.limit is None else [abs(v) for v in self.limit]))

    def draw(self, ax: plt.Axes, t: Array, colour: str) -> None:
        if self.env is not None:
            ax.fill_between(t, self.env[0], self.env[1], color=colour, alpha=0.15, lw=0)
        if self.run0 is not None:
            err, sd = self.run0
            ax.plot(t, 2 * sd, color=colour, lw=0.7, ls="-", alpha=0.55)
            ax.plot(t, -2 * sd, color=colour, lw=0.7, ls="-", alpha=0.55)
            ax.plot(t, err, color=colour, lw=1.0)
        elif self.note:
            ax.text(0.01, 0.95, self.note, transform=ax.transAxes, va="top", fontsize=8,
                    color=colour)
        if self.reference is not None:
            ax.plot(t, self.reference, color=REFERENCE_COLOUR, lw=0.7, alpha=0.8)
        for v in self.paper or ():
            ax.axhline(v, color=colour, ls="--", lw=1.2)
        for v in self.limit or ():
            ax.axhline(v, color="0.25", ls=":", lw=1.0)
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.grid(True, lw=0.3, alpha=0.5)


LEGEND = {
    "error": lambda: Line2D([], [], color="0.2", lw=1.0, label="run 0 error"),
    "sigma": lambda: Line2D([], [], color="0.2", lw=0.7, alpha=0.55, label="run 0 ±2σ"),
    "envelope": lambda: Patch(fc="0.2", alpha=0.15, label="Monte Carlo envelope (min/max)"),
    "paper": lambda: Line2D([], [], color="0.2", ls="--", lw=1.2, label="paper's range"),
    "reference": lambda: Line2D([], [], color=REFERENCE_COLOUR, lw=0.7,
                                label="gtsam run 0 error"),
    "limit": lambda: Line2D([], [], color="0.25", ls=":", lw=1.0, label="theoretical limit"),
}
"""The error grid's legend entries by name."""


@dataclass(frozen=True)
class ErrorGrid:
    """The layout of an error grid: its columns, size, y axes, labels, legend, title.

    ``ylabel`` is formatted with ``name`` (the row's estimator) and ``axis`` (the column).
    With ``sharey`` one y range holds every panel, else each column gets its own, or
    each group of columns in ``groups`` (e.g. ``((0, 1), (2,))``: x and y share one range,
    heading has its own).  ``legend`` lists the entries that may appear; only those drawn
    in some panel are shown.
    """

    axes: Sequence[str]
    width: float
    top: float
    ylabel: str
    legend: Sequence[str]
    title: str
    sharey: bool = False
    groups: Sequence[Sequence[int]] = ()
    units: Sequence[str] = ()
    """Per column, what ``{unit}`` in ``ylabel`` becomes."""
    windows: Sequence[float | None] = ()
    """Per column, the last time shown (``None``: the whole run), e.g. a transient."""


def _drawn(p: ErrorPanel) -> set[str]:
    """The legend entries panel ``p`` draws."""
    out = {"error", "sigma"} if p.run0 is not None else set()
    out |= {"envelope"} if p.env is not None else set()
    out |= {"paper"} if p.paper else set()
    out |= {"limit"} if p.limit else set()
    return out | ({"reference"} if p.reference is not None else set())


def error_grid(result: CampaignResult, path: Path, grid: ErrorGrid,
               panel: Callable[[str, int], ErrorPanel], colours: dict[str, str],
               names: Sequence[str] | None = None, note: str = "") -> None:
    """One row per estimator in ``names`` (default: the filters), one column per
    ``grid.axes`` entry: ``panel(name, column)``; ``note`` (e.g. which rows coincide) is
    printed above the legend."""
    names = list(filter_names(result) if names is None else names)
    t = run0(result).times
    fig, axes = plt.subplots(len(names), len(grid.axes),
                             figsize=(grid.width, grid.top + 0.4 + 1.9 * len(names)),
                             sharex="col", sharey=grid.sharey, squeeze=False)
    lim = np.zeros(len(grid.axes))
    drawn: set[str] = set()
    for row, name in enumerate(names):
        for col, axis in enumerate(grid.axes):
            ax, p = axes[row, col], panel(name, col)
            p.draw(ax, t, colours[name])
            drawn |= _drawn(p)
            lim[col] = max([lim[col], *p.extent()])
            unit = grid.units[col] if grid.units else ""
            ax.set_ylabel(grid.ylabel.format(name=name, axis=axis, unit=unit), fontsize=9)
            if row == 0:
                ax.set_title(f"{axis} error", fontsize=10)
            if row == len(names) - 1:
                ax.set_xlabel("time (s)")
    for group in grid.groups:
        lim[list(group)] = max(lim[list(group)])
    _set_limits(axes, lim, grid.sharey)
    for col, end in enumerate(grid.windows):
        if end is not None:
            axes[0, col].set_xlim(t[0], end)
    legend = [LEGEND[k]() for k in grid.legend if k in drawn]
    bottom_legend(fig, legend)
    lines = textwrap.wrap(note, int(grid.width * 15)) if note else []
    if lines:
        fig.text(0.5, (0.05 + 0.25 * bool(legend)) / fig.get_size_inches()[1],
                 "\n".join(lines), ha="center", va="bottom", fontsize=8)
    inch_layout(fig, len(names), len(grid.axes),
                bottom=0.55 + 0.25 * bool(legend) + 0.16 * len(lines), hgap=0.25)
    fig.suptitle(titled(result, grid.title), fontsize=11)
    save(fig, path)


def bottom_legend(fig: plt.Figure, handles: Sequence, ncols: int = 6) -> None:
    """A frameless legend along the bottom edge of the figure (rows of ``ncols``)."""
    if handles:
        fig.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.0),
                   fontsize=9, ncols=min(len(handles), ncols), frameon=False)


def legend_margin(entries: int, ncols: int, *, base: float = 0.55, row: float = 0.18
                  ) -> float:
    """Bottom margin (inches) for :func:`inch_layout` under a legend of ``entries`` entries in
    rows of ``ncols`` at the figure's bottom edge: ``base`` plus ``row`` per legend row."""
    return base + row * -(-entries // ncols)


def inch_layout(fig: plt.Figure, nrows: int, ncols: int, *, left: float = 0.8,
                right: float = 0.15, top: float = 0.65, bottom: float = 0.55,
                wgap: float = 0.85, hgap: float = 0.55, grid=None) -> None:
    """Place a grid of axes (the figure's subplots, or ``grid``, a GridSpec) with margins
    and gaps in inches: a fixed layout, about a third cheaper to draw than constrained
    layout (which lays out every tick label once more).  The defaults hold 9-point tick
    labels and axis labels, panel titles and a one-line bottom legend."""
    W, H = fig.get_size_inches()
    aw = max((W - left - right - (ncols - 1) * wgap) / ncols, 0.1)
    ah = max((H - top - bottom - (nrows - 1) * hgap) / nrows, 0.1)
    box = {"left": left / W, "right": 1.0 - right / W, "top": 1.0 - top / H,
           "bottom": bottom / H, "wspace": wgap / aw, "hspace": hgap / ah}
    if grid is None:
        fig.subplots_adjust(**box)
    else:
        grid.update(**box)


def readable_log_axis(ax: plt.Axes, axis: str = "y") -> None:
    """Label a log axis densely enough to read values off it: evenly spaced round numbers
    over less than 0.8 decades, 1-1.5-2-3-5-7 within a decade and a half, 1-2-5 within
    four decades, powers of ten beyond; plain numbers."""
    lo, hi = ax.get_ylim() if axis == "y" else ax.get_xlim()
    decades = math.log10(hi / lo) if lo > 0 and hi > lo else 1.0
    target = ax.yaxis if axis == "y" else ax.xaxis
    if decades <= 0.8:  # evenly spaced round numbers read best over a short span
        target.set_major_locator(MaxNLocator(nbins=7, steps=[1, 2, 2.5, 5, 10]))
    else:
        subs = ((1.0, 1.5, 2.0, 3.0, 5.0, 7.0) if decades <= 1.5 else
                (1.0, 2.0, 5.0) if decades <= 4 else (1.0,))
        target.set_major_locator(LogLocator(base=10.0, subs=subs))
    target.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    target.set_minor_locator(LogLocator(base=10.0, subs=np.arange(1.0, 10.0)))
    target.set_minor_formatter(NullFormatter())


def _set_limits(axes: np.ndarray, lim: Array, shared: bool) -> None:
    """Symmetric y limits 15 % beyond ``lim`` (one per column, or their largest)."""
    if shared:
        if lim.max() > 0.0:
            axes[0, 0].set_ylim(-1.15 * lim.max(), 1.15 * lim.max())
        return
    for col in range(axes.shape[1]):
        if lim[col] > 0:
            for row in range(axes.shape[0]):
                axes[row, col].set_ylim(-1.15 * lim[col], 1.15 * lim[col])
