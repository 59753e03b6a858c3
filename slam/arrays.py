r"""A user's own estimates through the workbench's report: :func:`report`.

Given the epochs ``t`` (E,), one or more estimators' estimates :math:`\hat x_k` (E, n) with
covariances :math:`P_k` (E, n, n) - or (R, E, ...) for R Monte Carlo runs - the truth
:math:`x_k` and optionally the innovations :math:`\nu_k` with their covariances
:math:`S_k`, it writes what a built-in kind writes: ``summary.json`` (per estimator and per
run: RMSE per component, ANEES with its χ²_{nR}/(nR) band and in-band share, NIS per dof
with its band, the consistency verdict), ``report.md`` / ``report.html`` with the tables,
and the figures (RMSE against the filter's own σ, NEES and NIS against their bands).
The NEES, NIS and bands are :mod:`estimators.consistency`'s; the verdict rule is
:func:`slam.render.tables.verdict`'s.  A run whose estimate or covariance turns non-finite
counts as diverged (with the epoch) and is left out of every statistic.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from estimators.consistency import nees_series, nis_stats
from estimators.spaces import wrap_angle
from slam.render.document import KindReport, Section
from slam.render.tables import (
    MISSING,
    anees_cell,
    consistency_rule,
    interval,
    num,
    percent,
    plain_table,
    verdict,
)
from slam.results import Array, CampaignResult, RunOutcome
from slam.scoring import anees_entries

KIND = "arrays"
Given = ArrayLike | Mapping[str, ArrayLike] | None


@dataclass(frozen=True, kw_only=True)
class ArrayScores:
    """One estimator on one run: err (E, n) estimate minus truth (NaN without truth),
    sigma (E, n) own σ (NaN without covariance), nees (E,), and per update nis, nis_dof
    and nis_epoch (U,); diverged / failure when the run turned non-finite."""

    name: str
    err: Array
    sigma: Array
    nees: Array
    nis: Array
    nis_dof: Array
    nis_epoch: Array
    time_s: float = 0.0
    diverged: bool = False
    failure: str | None = None


@dataclass(frozen=True)
class ArraysSource:
    """What the report's title reads (a built-in kind's world has the same fields)."""

    name: str
    description: str = ""
    kind: str = KIND
    labels: tuple[str, ...] = field(default=())
    units: tuple[str, ...] = field(default=())


def _per_name(value: Given, names: Sequence[str] | None, what: str) -> dict[str, Any] | None:
    if value is None:
        return None
    if isinstance(value, Mapping):
        if names is not None and list(value) != list(names):
            raise ValueError(f"{what}: names {list(value)} differ from the estimates' "
                             f"{list(names)}")
        return dict(value)
    if names is not None and len(names) != 1:
        raise ValueError(f"{what}: one array for {len(names)} estimators; give a mapping "
                         "name -> array")
    return {names[0] if names else "filter": value}


def _runs(a: ArrayLike, core: int, what: str, E: int) -> Array:
    """``a`` with a leading run axis: (R, E, *core dims)."""
    x = np.asarray(a, dtype=float)
    if x.ndim == core + 1:
        x = x[None]
    if x.ndim != core + 2 or x.shape[1] != E:
        raise ValueError(f"{what}: shape {np.shape(a)}; expected (E, ...) or (R, E, ...) "
                         f"with E = {E} epochs and {core} more axes")
    return x


def _shape_check(a: Array, want: tuple[int, ...], what: str) -> None:
    if a.shape != want:
        raise ValueError(f"{what}: shape {a.shape}; expected {want}")


def _scores(name: str, t: Array, est: Array, cov: Array | None, truth: Array | None,
            inn: Array | None, inn_cov: Array | None, wrap: Sequence[int]) -> ArrayScores:
    """One run's scores (module docstring)."""
    E, n = est.shape
    bad = ~np.all(np.isfinite(est), axis=1)
    if cov is not None:
        bad |= ~np.all(np.isfinite(cov), axis=(1, 2))
    err = np.full((E, n), np.nan) if truth is None else est - truth
    if truth is not None and len(wrap):
        err[:, list(wrap)] = wrap_angle(err[:, list(wrap)])
    sigma = np.full((E, n), np.nan)
    nees = np.full(E, np.nan)
    if cov is not None:
        with np.errstate(invalid="ignore"):
            sigma = np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2), 0.0, None))
        if truth is not None:
            nees = nees_series(err, cov)
    nis = nis_dof = nis_epoch = np.zeros(0)
    if inn is not None and inn_cov is not None:
        has = np.all(np.isfinite(inn), axis=1)
        nis_epoch = np.flatnonzero(has)
        nis = nees_series(inn[has], inn_cov[has])
        nis_dof = np.full(len(nis), float(inn.shape[1]))
    failure = None
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        failure = f"non-finite estimate or covariance at epoch {k} (t = {t[k]:.6g})"
    return ArrayScores(name=name, err=err, sigma=sigma, nees=nees, nis=nis,
                       nis_dof=nis_dof, nis_epoch=nis_epoch.astype(np.int64),
                       diverged=failure is not None, failure=failure)


def _rmse(err: Array, labels: Sequence[str]) -> dict[str, float]:
    return {lab: float(np.sqrt(np.nanmean(err[..., i] ** 2))) for i, lab in enumerate(labels)}


def _entry(scores: list[ArrayScores], labels: Sequence[str], has_truth: bool,
           has_cov: bool) -> dict[str, Any]:
    """The summary entry of one estimator over its runs."""
    good = [s for s in scores if not s.diverged]
    out: dict[str, Any] = {"runs_scored": len(good), "diverged_runs": len(scores) - len(good)}
    if len(good) < len(scores):
        out["failures"] = sorted({s.failure or "" for s in scores if s.diverged})
    if not good:
        return out
    n = len(labels)
    if has_truth:
        err = np.stack([s.err for s in good])
        out["rmse"] = _rmse(err, labels)
        out["final_error"] = {lab: float(np.sqrt(np.mean(err[:, -1, i] ** 2)))
                              for i, lab in enumerate(labels)}
    if has_truth and has_cov:
        out.update(anees_entries(np.stack([s.nees for s in good]), n, full=True))
        out["consistency"] = verdict(out) or "no NEES"
    nis = np.concatenate([s.nis for s in good])
    if nis.size:
        st = nis_stats(nis, np.concatenate([s.nis_dof for s in good]))
        if st:
            out.update({"nis_per_dof": st["per_dof"], "nis_bounds_95": st["band"],
                        "nis_updates": st["updates"], "nis_updates_inside_95": st["inside"],
                        "nis_updates_above_95": st["above"],
                        "nis_consistency": ("consistent" if st["band"][0] <= st["per_dof"]
                                            <= st["band"][1] else "optimistic"
                                            if st["per_dof"] > st["band"][1]
                                            else "pessimistic")})
    out["per_run"] = [_run_entry(i, s, labels) for i, s in enumerate(scores)]
    return out


def _run_entry(i: int, s: ArrayScores, labels: Sequence[str]) -> dict[str, Any]:
    if s.diverged:
        return {"run": i, "diverged": True, "failure": s.failure}
    out: dict[str, Any] = {"run": i, "diverged": False}
    if np.isfinite(s.err).any():
        out["rmse"] = _rmse(s.err, labels)
    v = s.nees[np.isfinite(s.nees)]
    if v.size:
        out["anees"] = float(v.mean() / len(labels))
    if s.nis.size and np.isfinite(s.nis).any():
        ok = np.isfinite(s.nis)
        out["nis_per_dof"] = float(s.nis[ok].sum() / s.nis_dof[ok].sum())
    return out


def summarize(name: str, scores: dict[str, list[ArrayScores]], labels: Sequence[str],
              units: Sequence[str], has_truth: bool, has_cov: bool,
              description: str = "") -> dict[str, Any]:
    """The ``summary.json`` dict (module docstring)."""
    runs = len(next(iter(scores.values())))
    return {"world": name, "kind": KIND, "runs": runs, "description": description,
            "components": list(labels), "units": list(units),
            "filters": {n: _entry(s, labels, has_truth, has_cov) for n, s in scores.items()}}


def rows(summary: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """The results table: RMSE per component, ANEES, epochs in band, verdict, NIS."""
    labels, units = summary["components"], summary["units"]
    header = ["estimator", *(f"RMSE {lab} ({u})" if u else f"RMSE {lab}"
                             for lab, u in zip(labels, units)),
              "ANEES [95 % band]", "epochs in band", "verdict", "NIS/dof [95 % band]",
              "diverged"]
    out = []
    for name, e in summary["filters"].items():
        rmse = e.get("rmse", {})
        nis = num(e.get("nis_per_dof"), ".2f")
        if nis != MISSING:
            nis = f"{nis} {interval(e.get('nis_bounds_95'), '.2f')}"
        out.append([name, *(num(rmse.get(lab), ".4g") for lab in labels), anees_cell(e),
                    percent(e.get("anees_steps_inside_95")), e.get("consistency", MISSING),
                    nis, f"{e['diverged_runs']}/{e['runs_scored'] + e['diverged_runs']}"])
    return header, out


def sections(summary: dict[str, Any]) -> list[Section]:
    header, body = rows(summary)
    n = len(summary["components"])
    return [Section("Errors and consistency", header, body,
                    f"NEES of the {n}-dof state, run-averaged per epoch and divided by {n}; "
                    "the band is the two-sided 95 % χ² band of that average for a consistent "
                    "estimator. NIS/dof: the summed NIS over the summed innovation dof, "
                    f"with its χ² band. {consistency_rule()}")]


def figures() -> dict[str, tuple[Any, str]]:
    """The error and consistency figures (matplotlib imported here, only when drawn)."""
    from slam.render.consistency import NeesSpec, consistency_figure
    from slam.render.figures import FigureSpec, figure_table, rmse_sigma_figure
    from slam.render.series import Component, column

    def errors(result: CampaignResult, path: Path) -> None:
        src = result.world
        comps = [Component(lab, u, column("err", i), column("sigma", i))
                 for i, (lab, u) in enumerate(zip(src.labels, src.units))]
        rows_ = [comps[i:i + 3] for i in range(0, len(comps), 3)]
        rmse_sigma_figure(rows_, "RMSE and own σ")(result, path)

    def consistency(result: CampaignResult, path: Path) -> None:
        n = len(result.world.labels)
        has_nees = any("anees" in e for e in result.summary["filters"].values())
        consistency_figure([NeesSpec(f"NEES / {n}", n, lambda s: s.nees)] if has_nees else [],
                           estimators=lambda r: list(r.summary["filters"]))(result, path)

    return figure_table([FigureSpec("errors.png", "Monte Carlo RMSE (solid) and RMS of the "
                                    "estimator's own σ (dashed) per component.", errors),
                         FigureSpec("consistency.png", "NEES and NIS per epoch, run-averaged, "
                                    "against their 95 % χ² bands.", consistency)])


def _report(has_truth: bool, has_nees: bool, has_nis: bool) -> KindReport:
    def figs() -> dict[str, tuple[Any, str]]:
        keep = {"errors.png": has_truth, "consistency.png": has_nees or has_nis}
        return {k: v for k, v in figures().items() if keep[k]}

    return KindReport(what="a user's estimates", sections=sections, figures=figs,
                      text_table=lambda s: plain_table(*rows(s)))


def report(times: ArrayLike, estimates: Given, covariances: Given = None, *,
           truth: ArrayLike | None = None, innovations: Given = None,
           innovation_covs: Given = None, out: str | Path, name: str = "arrays",
           labels: Sequence[str] | None = None, units: Sequence[str] | None = None,
           angles: Sequence[int] = (), description: str = "", plots: bool = True,
           ) -> dict[str, Any]:
    """Score a user's estimates and write the report folder ``out`` (module docstring).

    ``estimates`` (E, n) or (R, E, n), or a mapping estimator name -> such arrays;
    ``covariances`` likewise (E, n, n); ``truth`` (E, n) or (R, E, n); ``innovations``
    (E, m) per estimator, NaN rows at epochs without an update, with ``innovation_covs``
    (E, m, m); ``labels`` / ``units`` name the n components; ``angles`` are component
    indices whose errors are wrapped to (-π, π].  ``out`` must be absent, empty or an
    earlier output (written atomically).  -> the summary dict.  Bad shapes raise
    ``ValueError`` naming the argument."""
    from slam.render.output import write_outputs

    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or not t.size or not np.all(np.isfinite(t)):
        raise ValueError(f"times: shape {t.shape}; expected (E,) finite epochs, E >= 1")
    E = len(t)
    est = {k: _runs(v, 1, f"estimates[{k!r}]", E)
           for k, v in (_per_name(estimates, None, "estimates") or {}).items()}
    if not est:
        raise ValueError("estimates: none given")
    names = list(est)
    R, n = next(iter(est.values())).shape[0], next(iter(est.values())).shape[2]
    for k, v in est.items():
        _shape_check(v, (R, E, n), f"estimates[{k!r}]")
    cov = {k: _runs(v, 2, f"covariances[{k!r}]", E)
           for k, v in (_per_name(covariances, names, "covariances") or {}).items()}
    for k, v in cov.items():
        _shape_check(v, (R, E, n, n), f"covariances[{k!r}]")
    tru = None if truth is None else _runs(truth, 1, "truth", E)
    if tru is not None:
        tru = np.broadcast_to(tru, (R, E, n)) if tru.shape[0] == 1 else tru
        _shape_check(tru, (R, E, n), "truth")
    inn = {k: _runs(v, 1, f"innovations[{k!r}]", E)
           for k, v in (_per_name(innovations, names, "innovations") or {}).items()}
    inn_cov = {k: _runs(v, 2, f"innovation_covs[{k!r}]", E)
               for k, v in (_per_name(innovation_covs, names, "innovation_covs") or {}).items()}
    if set(inn) != set(inn_cov):
        raise ValueError("innovations and innovation_covs: give both for the same estimators")
    for k, v in inn.items():
        m = v.shape[2]
        _shape_check(v, (R, E, m), f"innovations[{k!r}]")
        _shape_check(inn_cov[k], (R, E, m, m), f"innovation_covs[{k!r}]")
    labels = tuple(labels) if labels is not None else tuple(f"x{i}" for i in range(n))
    units = tuple(units) if units is not None else ("",) * n
    if len(labels) != n or len(units) != n:
        raise ValueError(f"labels / units: {len(labels)} / {len(units)} names for {n} "
                         "components")
    scores = {k: [_scores(k, t, est[k][r], cov[k][r] if k in cov else None,
                          None if tru is None else tru[r],
                          inn[k][r] if k in inn else None,
                          inn_cov[k][r] if k in inn_cov else None, angles)
                  for r in range(R)] for k in names}
    summary = summarize(name, scores, labels, units, tru is not None, bool(cov), description)
    outcomes = [RunOutcome(r, {k: scores[k][r] for k in names},
                           tracks={k: est[k][r] for k in names} if r == 0 else {},
                           truth=None if tru is None else tru[r], times=t)
                for r in range(R)]
    result = CampaignResult(ArraysSource(name, description, KIND, labels, units), summary,
                            outcomes)
    write_outputs(result, _report(tru is not None, tru is not None and bool(cov), bool(inn)),
                  Path(out), plots=plots)
    return summary
