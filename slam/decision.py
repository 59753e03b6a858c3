"""The part of a campaign summary that decides: the paired ranking of the filters per
headline metric (:mod:`slam.ranking`), each filter's settings, and a headline sentence
saying which filter is best, by how much, whether that is significant, which filters are
consistent and how far the best is from the smoother.

A kind's ``summarize`` builds its own entries, then calls :func:`decide` with its headline
metrics (per-run MSE arrays) and the keys of its headline consistency score; every kind's
report renders the result the same way (:mod:`slam.render.decision`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from slam.ranking import ONE_RUN, Metric, rank
from slam.render.tables import verdict
from slam.results import REFERENCE


@dataclass(frozen=True)
class Consistency:
    """Where a kind's summary entries keep the headline consistency score (the ANEES,
    its 95 % band, the in-band and above-band epoch fractions) and what it is of."""

    key: str = "anees"
    band: str = "anees_bounds_95"
    inside: str = "anees_steps_inside_95"
    above: str = "anees_steps_above_95"
    label: str = "pose"

    def verdict(self, entry: Mapping[str, Any]) -> str:
        return verdict(dict(entry), self.key, self.band, self.inside, self.above)


def _pct(row: Mapping[str, Any]) -> str:
    return f"{row['delta_percent']:+.1f} %"


def _metric_sentence(block: Mapping[str, Any], unit_fmt: str = ".3g") -> str:
    label, unit = block["label"][:1].upper() + block["label"][1:], block["unit"]
    if "rows" not in block:
        return f"{label}: no ranking ({block.get('reason', 'no paired runs')})."
    rows = block["rows"]
    best = block["best"]
    rmse = f"RMSE {rows[best]['rmse']:{unit_fmt}} {unit}"
    if block.get("significance"):
        head = f"{label}: {best} has the lowest MSE on a single run ({rmse}; {ONE_RUN})"
    else:
        head = f"{label}: {best} has the lowest MSE over {block['runs']} paired runs ({rmse})"
    others = []
    for name in block["order"][1:]:
        r = rows[name]
        if r["verdict"] == "equal":
            others.append(f"{name} equal to 1e-6")
        elif r["verdict"] == ONE_RUN:
            others.append(f"{name} {_pct(r)}")
        elif r["z"] is None:
            others.append(f"{name} {_pct(r)} (every run worse)")
        else:
            others.append(f"{name} {_pct(r)} ({r['verdict']}, {r['z']:.1f} s.e.)")
    text = head + ("; " + ", ".join(others) if others else "") + "."
    ref = block.get("reference")
    if ref and ref.get("rmse") is not None and ref.get("best_over_reference") is not None:
        text += (f" The {ref['name']} smoother's RMSE is {ref['rmse']:{unit_fmt}} {unit}: the "
                 f"best filter is {ref['best_over_reference']:.2f}× it.")
    return text


def _consistency_sentence(entries: Mapping[str, Mapping[str, Any]], names: Sequence[str],
                          cons: Consistency, variants: Mapping[str, str]) -> str:
    verdicts = {n: cons.verdict(entries.get(n, {})) for n in names}
    good = [n for n in names if verdicts[n] == "consistent"]
    scored = [n for n in names if verdicts[n]]
    if not scored:
        return f"No {cons.label} NEES was scored."
    text = (f"Consistent ({cons.label} ANEES in its band and at least 90 % of epochs in it): "
            f"{', '.join(good) if good else 'none'}.")
    for n in names:
        inv = variants.get(n)
        if verdicts[n] == "optimistic" and inv and inv not in names:
            e = entries[n]
            text += (f" {n} is optimistic (ANEES {e[cons.key]:.2f}); its invariant-error "
                     f"variant {inv} (--filters {inv}) is built for this.")
    return text


def _json_settings(values: Mapping[str, Any]) -> dict[str, Any]:
    """A filter's settings as summary.json holds them: an infinite value (γ = ∞, the
    Kalman twin) as the string ``"inf"`` rather than a bare null."""
    return {k: (str(v) if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in values.items()}


def decide(summary: Mapping[str, Any], metrics: Sequence[Metric], *, filters: Sequence[str],
           consistency: Consistency | None = Consistency(), reference: str | None = REFERENCE,
           settings: Mapping[str, Mapping[str, Any]] | None = None,
           settings_text: Mapping[str, str] | None = None,
           variants: Mapping[str, str] | None = None, tuned: Any = None) -> dict[str, Any]:
    """``summary`` with ``ranking`` (metric key -> :func:`slam.ranking.rank` block),
    ``headline`` (the decision in sentences) and, per filter entry, ``settings`` /
    ``settings_text`` (its tuning constants) added; a new dict.

    ``filters`` are ranked (baselines and the reference are not), each metric among the
    filters it has a per-run MSE of (a kind's metric may hold only some of its filters,
    e.g. position for the filters that estimate one); ``variants`` maps a standard filter
    to its invariant-error variant for the headline's hint.  ``tuned`` (a world's filters
    table: ``settings_of(name)``, ``describe(name)``, e.g.
    :class:`worlds.common.TunedFilters`) gives ``settings`` and ``settings_text`` of every
    filter in ``filters``.
    """
    if tuned is not None:
        settings = {n: tuned.settings_of(n) for n in filters}
        settings_text = {n: tuned.describe(n) for n in filters}
    out = dict(summary)
    entries = {k: dict(v) for k, v in (summary.get("filters") or {}).items()}
    for name in filters:
        if name in entries:
            if settings is not None:
                entries[name]["settings"] = _json_settings(settings.get(name, {}))
            if settings_text is not None:
                entries[name]["settings_text"] = settings_text.get(name, "")
    out["filters"] = entries
    out["ranking"] = {m.key: rank(m, [f for f in filters if f in m.per_run_mse], reference)
                      for m in metrics}
    parts = [_metric_sentence(b) for b in out["ranking"].values()]
    if consistency is not None:
        parts.append(_consistency_sentence(entries, list(filters), consistency,
                                           variants or {}))
    out["headline"] = " ".join(parts)
    return out
