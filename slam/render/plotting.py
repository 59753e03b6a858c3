"""Figure helpers shared by the kinds' reports: the Agg backend, resolution, colours,
saving, run 0's tracks, covariance ellipses."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the backend)
from matplotlib.patches import Ellipse  # noqa: E402

from slam.results import Array, CampaignResult  # noqa: E402

DPI = 110
FILTER_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:brown",
                  "tab:pink", "tab:olive", "tab:cyan", "tab:purple", "tab:gray")
REFERENCE_COLOUR = "#7a3b8f"


def filter_names(result: CampaignResult) -> list[str]:
    """The campaign's filters, in summary order."""
    return list((result.summary.get("filters") or {}).keys())


def filter_colours(names) -> dict[str, str]:
    """One colour per filter, in the tab10 order."""
    return {n: FILTER_COLOURS[i % len(FILTER_COLOURS)] for i, n in enumerate(names)}


def run0(result: CampaignResult):
    """Run 0's outcome, which keeps the full tracks for plotting."""
    first = result.outcomes[0]
    if first.truth is None or first.times is None or not first.tracks:
        raise ValueError("run 0 of the campaign kept no tracks: nothing to plot")
    return first


def good_scores(result: CampaignResult, name: str) -> list:
    """``name``'s scores over the runs it did not diverge on."""
    return [o.scores[name] for o in result.outcomes
            if name in o.scores and not o.scores[name].diverged]


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



def envelope(scores: list, values: Callable) -> tuple[Array, Array] | None:
    """Monte Carlo envelope (per-epoch min and max over runs) of ``values(score)``."""
    if not scores:
        return None
    a = np.stack([values(s) for s in scores])
    if not np.isfinite(a).any():
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # epochs with no value in any run
        return np.nanmin(a, axis=0), np.nanmax(a, axis=0)
