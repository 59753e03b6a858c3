"""Per-epoch statistics over a campaign's runs, drawn from the per-run score arrays the
workers returned (nothing is re-run): Monte Carlo RMSE, the RMS of an estimator's own σ,
run-averaged NEES and NIS with their χ² bands, per-run ANEES, filter-minus-filter
differences and per-epoch map summaries.

A kind says what its score objects hold through :class:`Component` (one error component
with its σ, in the plotted unit) and small accessor functions; everything here is
kind-agnostic.  Only runs an estimator did not diverge on are used.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from slam.results import Array, CampaignResult
from slam.scoring import chi2_ppf

Scores = Any
"""One estimator's per-run score object (RunScores, DroneScores, AttitudeScores, ...)."""


@dataclass(frozen=True)
class Component:
    """One error component of an estimator, per epoch, in the plotted unit.

    label : panel title (``"x"``, ``"heading"``, ``"along-track"``); unit : ``"m"``, ``"deg"``;
    err : scores -> (E,) estimate minus truth; sigma : scores -> (E,) the estimator's own
    standard deviation (``None``: it has none); group : what the component belongs to
    (``"position"``, ``"velocity"``), shown in the axis label.
    """

    label: str
    unit: str
    err: Callable[[Scores], Array]
    sigma: Callable[[Scores], Array] | None = None
    group: str = ""

    @property
    def axis_label(self) -> str:
        return f"{self.group} {self.label}".strip()


def column(attr: str, col: int, scale: float = 1.0) -> Callable[[Scores], Array | None]:
    """A getter of column ``col`` of the scores' (E, k) array ``attr`` times ``scale``
    (None when the scores do not carry it)."""
    def get(s: Scores) -> Array | None:
        a = getattr(s, attr, None)
        return None if a is None else np.asarray(a[:, col], dtype=float) * scale
    return get


def good_scores(result: CampaignResult, name: str) -> list[Scores]:
    """``name``'s scores over the runs it did not diverge on."""
    return [o.scores[name] for o in result.outcomes
            if name in o.scores and not o.scores[name].diverged]


def run_statistic(result: CampaignResult, name: str,
                  statistic: Callable[[Array], Array]) -> Array | None:
    """``statistic`` of the (R, E, k) stack of ``name``'s ``err`` arrays over the runs it
    did not diverge on (NaN warnings silenced); None if it diverged on every run."""
    scores = good_scores(result, name)
    if not scores:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # epochs with no value in any run
        return statistic(np.stack([s.err for s in scores]))


def n_epochs(result: CampaignResult) -> int:
    """Epochs of run 0 (the time axis every figure uses)."""
    t = result.outcomes[0].times
    return 0 if t is None else len(t)


def stack(rows: list[Array], length: int) -> Array | None:
    """Per-run series as an (R, length) float array (shorter runs padded with NaN)."""
    if not rows:
        return None
    out = np.full((len(rows), length), np.nan)
    for i, r in enumerate(rows):
        r = np.asarray(r, dtype=float)[:length]
        out[i, :len(r)] = r
    return out


def stacked(result: CampaignResult, name: str, fn: Callable[[Scores], Array | None]
            ) -> Array | None:
    """``fn(scores)`` of every good run of ``name`` as (R, E), or None if none has it."""
    rows = [fn(s) for s in good_scores(result, name)]
    return stack([r for r in rows if r is not None], n_epochs(result))


def _quiet(fn: Callable[[], Array]) -> Array:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # epochs with no value in any run
        return fn()


def rms(a: Array) -> Array:
    """Root mean square over runs (axis 0) per epoch, NaN where no run has a value."""
    return _quiet(lambda: np.sqrt(np.nanmean(a**2, axis=0)))


def mean(a: Array) -> Array:
    """Mean over runs per epoch, NaN where no run has a value."""
    return _quiet(lambda: np.nanmean(a, axis=0))


def chi2_band(dof: Array | float, level: float = 0.95) -> tuple[Array, Array]:
    """Two-sided band of a χ² variable with ``dof`` degrees of freedom divided by ``dof``
    (NaN where ``dof`` is 0)."""
    d = np.asarray(dof, dtype=float)
    a = (1.0 - level) / 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        lo = np.where(d > 0, chi2_ppf(a, np.maximum(d, 1)) / np.maximum(d, 1), np.nan)
        hi = np.where(d > 0, chi2_ppf(1 - a, np.maximum(d, 1)) / np.maximum(d, 1), np.nan)
    return lo, hi


def fraction_inside(values: Array, lo: Array | float, hi: Array | float) -> float | None:
    """Fraction of the finite ``values`` inside ``[lo, hi]`` (None if there are none)."""
    v, lo, hi = np.broadcast_arrays(np.asarray(values, float), lo, hi)
    ok = np.isfinite(v) & np.isfinite(lo) & np.isfinite(hi)
    return float(np.mean((v[ok] >= lo[ok]) & (v[ok] <= hi[ok]))) if ok.any() else None


@dataclass(frozen=True)
class EpochConsistency:
    """A run-averaged normalised statistic per epoch with its per-epoch 95 % band."""

    value: Array
    lo: Array
    hi: Array

    @property
    def inside(self) -> float | None:
        return fraction_inside(self.value, self.lo, self.hi)


def nees_per_epoch(result: CampaignResult, name: str, nees: Callable[[Scores], Array],
                   dof: int) -> EpochConsistency | None:
    """Run-averaged NEES / dof per epoch and its band (χ² with dof × runs-with-a-value)."""
    a = stacked(result, name, nees)
    if a is None:
        return None
    count = np.isfinite(a).sum(axis=0)
    total = np.where(np.isfinite(a), a, 0.0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        value = np.where(count > 0, total / np.maximum(count, 1) / dof, np.nan)
    lo, hi = chi2_band(count * dof)
    return EpochConsistency(value, lo, hi)


def nis_events(s: Scores, length: int) -> tuple[Array, Array, Array]:
    """``(epoch, nis, dof)`` of every update of one run: placed by ``nis_epoch`` when the
    scores carry it, else ``nis`` must be one value per epoch (NaN where none) with a
    single ``nis_dof`` (the attitude kind); empty when the updates cannot be placed."""
    nis = np.asarray(s.nis, dtype=float)
    epoch = getattr(s, "nis_epoch", None)
    if epoch is not None:
        epoch = np.asarray(epoch, dtype=int)
        keep = epoch < length
        return epoch[keep], nis[keep], np.asarray(s.nis_dof, dtype=float)[keep]
    if nis.size == 0 or np.ndim(s.nis_dof) != 0:
        return np.zeros(0, int), np.zeros(0), np.zeros(0)
    ok = np.flatnonzero(np.isfinite(nis[:length]))
    return ok, nis[ok], np.full(len(ok), float(s.nis_dof))


def nis_per_epoch(result: CampaignResult, name: str) -> EpochConsistency | None:
    """Σ NIS / Σ dof over runs per epoch, with its χ²(Σ dof) band; None without updates."""
    E = n_epochs(result)
    total, dof = np.zeros(E), np.zeros(E)
    for s in good_scores(result, name):
        e, nis, d = nis_events(s, E)
        total += np.bincount(e, weights=nis, minlength=E)[:E]
        dof += np.bincount(e, weights=d, minlength=E)[:E]
    if not dof.any():
        return None
    with np.errstate(invalid="ignore", divide="ignore"):
        value = np.where(dof > 0, total / np.maximum(dof, 1e-300), np.nan)
    lo, hi = chi2_band(dof)
    return EpochConsistency(value, lo, hi)


def per_run_anees(result: CampaignResult, name: str, nees: Callable[[Scores], Array],
                  dof: int) -> Array:
    """Each good run's time-averaged NEES / dof."""
    out = []
    for s in good_scores(result, name):
        v = np.asarray(nees(s), dtype=float)
        v = v[np.isfinite(v)]
        if v.size:
            out.append(float(v.mean()) / dof)
    return np.array(out)


def per_run_nis(result: CampaignResult, name: str) -> Array:
    """Each good run's Σ NIS / Σ dof."""
    E, out = n_epochs(result), []
    for s in good_scores(result, name):
        _, nis, d = nis_events(s, E)
        if d.sum() > 0:
            out.append(float(nis.sum() / d.sum()))
    return np.array(out)


def paired_differences(result: CampaignResult, name: str, base: str,
                       fn: Callable[[Scores], Array]) -> Array | None:
    """``fn(name) - fn(base)`` per run on the runs neither diverged on, as (R, E).

    Truth cancels: this is the difference of the two estimates on the same data."""
    rows = [np.asarray(fn(o.scores[name]), float) - np.asarray(fn(o.scores[base]), float)
            for o in result.outcomes
            if name in o.scores and base in o.scores
            and not o.scores[name].diverged and not o.scores[base].diverged]
    return stack(rows, n_epochs(result))


@dataclass(frozen=True)
class MapEpochs:
    """A filter's map per epoch over the runs: landmark RMSE (m), landmark NEES / dof with
    its band, mean landmarks in the state, mean trace of the map covariance (m²)."""

    rmse: Array
    nees: EpochConsistency
    count: Array
    trace: Array


def map_per_epoch(result: CampaignResult, name: str) -> MapEpochs | None:
    """:class:`MapEpochs` of filter ``name`` from its runs' ``map_series`` (None if none)."""
    series = [s.map_series for s in good_scores(result, name)
              if getattr(s, "map_series", None) is not None]
    if not series:
        return None
    E = n_epochs(result)

    def field(attr: str) -> Array:
        return stack([getattr(m, attr) for m in series], E)

    scored, sq, nees, count = field("scored"), field("sq_err"), field("nees"), field(
        "nees_count")
    dof = series[0].dof
    with np.errstate(invalid="ignore", divide="ignore"):
        s_scored, s_count = np.nansum(scored, axis=0), np.nansum(count, axis=0)
        rmse = np.where(s_scored > 0, np.sqrt(np.nansum(sq, axis=0) / s_scored), np.nan)
        value = np.where(s_count > 0, np.nansum(nees, axis=0) / (dof * s_count), np.nan)
    lo, hi = chi2_band(s_count * dof)
    return MapEpochs(rmse, EpochConsistency(value, lo, hi), mean(field("n")),
                     mean(field("trace")))


COINCIDE_RTOL = 0.01
"""Two curves coincide when their largest difference is below this fraction of the
larger curve's largest magnitude (they then overdraw each other at a figure's scale)."""


def coinciding(curves: dict[str, Array | None], rtol: float = COINCIDE_RTOL
               ) -> list[tuple[str, str, float]]:
    """Pairs ``(a, b, largest |a - b|)`` of the curves (same epochs: curves of another
    length are not compared; NaN left out) whose
    largest difference is below ``rtol`` × the larger of their largest magnitudes, each
    curve paired with the first curve it coincides with (in the dict's order)."""
    names = [n for n, c in curves.items() if c is not None and np.isfinite(c).any()]
    out: list[tuple[str, str, float]] = []
    used: set[str] = set()
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if b in used:
                continue
            ca, cb = np.asarray(curves[a]), np.asarray(curves[b])
            if ca.shape != cb.shape:  # at other epochs: not the same curve
                continue
            ok = np.isfinite(ca) & np.isfinite(cb)
            if not ok.any():
                continue
            diff = float(np.max(np.abs(ca[ok] - cb[ok])))
            scale = max(float(np.max(np.abs(ca[ok]))), float(np.max(np.abs(cb[ok]))))
            if diff <= rtol * scale:
                out.append((a, b, diff))
                used.add(b)
    return out


def coincidence_note(columns: dict[str, dict[str, Array | None]], units: dict[str, str],
                     what: str = "curves", rtol: float = COINCIDE_RTOL) -> str:
    """One sentence naming, pair by pair, the estimators whose curves coincide
    (:func:`coinciding`) in some of the figure's ``columns`` (column -> estimator -> curve),
    with the largest difference per column in its unit (``units``); ``""`` when none do.
    E.g. ``"Overdrawn - run 0's curves that coincide, with their largest difference: ukf
    and uthinf (east 0.0002 ′, north 0.0005 ′)."``"""
    pairs: dict[tuple[str, str], list[str]] = {}
    for col, curves in columns.items():
        for a, b, d in coinciding(curves, rtol):
            pairs.setdefault((a, b), []).append(f"{col} {d:.2g} {units.get(col, '')}".rstrip())
    text = "; ".join(f"{a} and {b} ({', '.join(v)})" for (a, b), v in pairs.items())
    return (f"Overdrawn - {what} that coincide, with their largest difference: {text}."
            if text else "")
