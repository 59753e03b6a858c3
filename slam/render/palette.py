"""Colours and names of a campaign's estimators for figures and scenes, without matplotlib
(the 3-D scene and the reports' tables use them on runs that draw no figure)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from slam.results import REFERENCE, CampaignResult

FILTER_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:brown",
                  "tab:pink", "tab:olive", "tab:cyan", "tab:purple", "tab:gray")
EIGHT_COLOURS = FILTER_COLOURS[:8]
"""The palette the drone and attitude reports cycle through."""
REFERENCE_COLOUR = "#7a3b8f"
BASELINE_COLOUR = "0.55"


def filter_names(result: CampaignResult) -> list[str]:
    """The campaign's filters, in summary order."""
    return list((result.summary.get("filters") or {}).keys())


def filter_colours(names: Iterable[str], palette: Sequence[str] = FILTER_COLOURS
                   ) -> dict[str, str]:
    """One colour per filter, in the palette's (tab10) order."""
    return {n: palette[i % len(palette)] for i, n in enumerate(names)}


def estimator_colours(names: Iterable[str], palette: Sequence[str] = FILTER_COLOURS,
                      baselines: Sequence[str] = ()) -> dict[str, str]:
    """A palette colour per filter in ``names`` (the smoother left out), then the
    smoother's and the ``baselines``' fixed colours."""
    out = filter_colours([n for n in names if n != REFERENCE], palette)
    out[REFERENCE] = REFERENCE_COLOUR
    out.update(dict.fromkeys(baselines, BASELINE_COLOUR))
    return out


def titled(result: CampaignResult, what: str) -> str:
    """``"<world>: <what>"``, a figure's title."""
    return f"{result.summary.get('world', '')}: {what}"


def run0(result: CampaignResult):
    """Run 0's outcome, which keeps the full tracks for plotting."""
    first = result.outcomes[0]
    if first.truth is None or first.times is None or not first.tracks:
        raise ValueError("run 0 of the campaign kept no tracks: nothing to plot")
    return first
