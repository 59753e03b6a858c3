r"""Checks for another project's unit tests: a filter (or a model) on tiny worlds.

Plain functions that raise ``AssertionError`` with a message naming the filter, the run,
the epoch and the figure of the report that shows the failure (usable from pytest,
unittest or a script)::

    result = testing.run("tiny-star-sensor", ["srckf"], using={"srckf": my_filter})
    testing.no_divergence(result)
    testing.nees_in_band(result)                 # ANEES in its χ² band over the runs
    testing.nis_in_band(result)                  # NIS per dof in its χ² band
    testing.consistent(result)                   # both
    testing.error_within(result, factor=2.0)     # the error within 2× the smoother's
    testing.agrees_with(result, "srckf", rtol=1e-6)   # the built-in filter's errors

``using`` puts a filter of one's own (a zero-argument factory returning an
:class:`estimators.Filter`) in the place of a built-in filter name for the run, so the
world's models and settings are used unchanged.  The tiny worlds (:func:`tiny_worlds`)
ship with the package (``slam/testing/worlds/*.toml``, not bundled worlds): every kind
with a smoother, each run well under a second of CPU.  With the built-in filters
``tiny-planar`` and ``tiny-fixed-wing`` pass every check; the attitude worlds
(``tiny-star-sensor``, ``tiny-ship``, ``tiny-alignment``) are too short for the filters to
settle from their worlds' initial errors, so their NEES / NIS are out of band (use them for
:func:`no_divergence` and :func:`agrees_with`).

The χ² bands are :mod:`estimators.consistency`'s: for R runs of an n-dof NEES the ANEES
band is :math:`\chi^2_{nR}` quantiles / (nR); a filter is in band when its ANEES is inside
and at least ``min_inside`` of the epochs' run-averaged NEES are.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np

from estimators import consistency
from slam.results import REFERENCE, CampaignResult

WORLDS = files(__name__) / "worlds"
ERROR_METRICS: dict[str, str] = {
    "planar-slam": "pos_rmse_m", "attitude": "att_rms_steady_arcsec", "ship": "att_rms_arcmin",
    "alignment": "rms_whole_arcmin", "fixed-wing": "pos_rmse_m",
}
"""The summary key :func:`error_within` and :func:`agrees_with` compare, per kind."""
NEES_ATTRIBUTES = ("nees", "nees6")
ERROR_ATTRIBUTES = ("err", "err_body", "err_pos")
FIGURES = {"nees": "the report's consistency / NEES figure", "error": "the error figures"}

__all__ = ["tiny_worlds", "tiny_world", "run", "substituted", "no_divergence", "nees_in_band",
           "nis_in_band", "consistent", "error_within", "agrees_with"]


def tiny_worlds() -> list[str]:
    """The names of the tiny worlds (one per kind)."""
    return sorted(p.name.removesuffix(".toml") for p in WORLDS.iterdir()
                  if p.name.endswith(".toml"))


def tiny_world(name: str) -> Any:
    """A tiny world, validated (``tiny-planar``, ``tiny-star-sensor``, ...)."""
    from slam.registry import load_world

    if name not in tiny_worlds():
        raise ValueError(f"no tiny world {name!r}; choose from {', '.join(tiny_worlds())}")
    with contextlib.ExitStack() as stack:
        from importlib.resources import as_file

        path = stack.enter_context(as_file(WORLDS / f"{name}.toml"))
        return load_world(Path(path))


@contextlib.contextmanager
def substituted(filters: Mapping[str, Callable[[], Any]]) -> Iterator[None]:
    """Within the block, :func:`estimators.make_filter` of each name in ``filters``
    returns that factory's filter (the kinds build their filters through it; inside a
    factory the built-in filters are built as usual)."""
    import estimators.filters as ef

    build = ef._build
    inside: list[bool] = []  # a factory may itself build the built-in filter

    def patched(name: str, settings: dict[str, Any]) -> Any:
        if name not in filters or inside:
            return build(name, settings)
        inside.append(True)
        try:
            return filters[name]()
        finally:
            inside.pop()

    ef._build = patched
    try:
        yield
    finally:
        ef._build = build


def run(world: str | Any, filters: Sequence[str] | None = None, *, runs: int | None = None,
        seed: int | None = None, using: Mapping[str, Callable[[], Any]] | None = None
        ) -> CampaignResult:
    """A campaign on ``world`` (a tiny world's name, a world file or a world) in this
    process, ``using`` one's own filters in place of built-in names (:func:`substituted`)."""
    from slam.campaign import run_campaign
    from slam.registry import load_world

    if isinstance(world, str):
        world = tiny_world(world) if world in tiny_worlds() else load_world(world)
    with substituted(using or {}):
        return run_campaign(world, filters=filters, runs=runs, seed=seed, workers=1,
                            executor="per-run" if using else "batched")


def _filters(result: CampaignResult, names: Sequence[str] | None) -> list[str]:
    return list(names) if names is not None else list(result.summary["filters"])


def _first(scores: Any, attrs: Sequence[str]) -> np.ndarray | None:
    for a in attrs:
        v = getattr(scores, a, None)
        if v is not None:
            return np.asarray(v, dtype=float)
    return None


def _where(result: CampaignResult, epoch: int) -> str:
    t = result.outcomes[0].times
    return (f"epoch {epoch}" + (f" (t = {float(t[epoch]):.6g})" if t is not None
                                and epoch < len(t) else ""))


def no_divergence(result: CampaignResult, filters: Sequence[str] | None = None) -> None:
    """No run of the filters (and the smoother) diverged."""
    bad = []
    for o in result.outcomes:
        for name in [*_filters(result, filters), REFERENCE]:
            s = o.scores.get(name)
            if s is None or not s.diverged:
                continue
            err = _first(s, ERROR_ATTRIBUTES)
            where = ""
            if err is not None:
                gone = np.flatnonzero(~np.all(np.isfinite(err.reshape(len(err), -1)), axis=1))
                where = f" at {_where(result, int(gone[0]))}" if gone.size else ""
            bad.append(f"run {o.run}: {name} diverged{where}: {s.failure}")
    if bad:
        raise AssertionError(f"{len(bad)} divergence(s) on {result.summary['world']}; "
                             + "; ".join(bad[:5]))


def _dof(runs: int, band: Sequence[float]) -> int:
    """The NEES dof whose ANEES band for ``runs`` runs is ``band``."""
    return min(range(1, 61), key=lambda d: abs(consistency.anees_band(runs, d)[0] - band[0]))


def nees_in_band(result: CampaignResult, filters: Sequence[str] | None = None,
                 min_inside: float = 0.9) -> None:
    """Each filter's ANEES inside its 95 % band and at least ``min_inside`` of the epochs'
    run-averaged NEES inside it; the message names the first epoch outside and the run
    with the largest ANEES."""
    bad = []
    for name in _filters(result, filters):
        e = result.summary["filters"][name]
        if "anees" not in e:
            bad.append(f"{name}: no NEES in the summary")
            continue
        lo, hi = e["anees_bounds_95"]
        inside = e.get("anees_steps_inside_95", e.get("anees_inside_95"))
        if lo <= e["anees"] <= hi and inside is not None and inside >= min_inside:
            continue
        per_run = [(o.run, _first(o.scores[name], NEES_ATTRIBUTES)) for o in result.outcomes
                   if not o.scores[name].diverged]
        per_run = [(r, v) for r, v in per_run if v is not None]
        detail = ""
        if per_run:
            dof = _dof(len(per_run), (lo, hi))
            avg = consistency.per_epoch_anees(np.stack([v for _, v in per_run]), dof)
            out = np.flatnonzero(np.isfinite(avg) & ((avg < lo) | (avg > hi)))
            worst = max(per_run, key=lambda rv: np.nanmean(rv[1]))
            if out.size:
                detail += (f"; first epoch outside: {_where(result, int(out[0]))}, "
                           f"run-averaged NEES/{dof} = {avg[out[0]]:.3g}")
            detail += f"; largest: run {worst[0]} (ANEES {np.nanmean(worst[1]) / dof:.3g})"
        share = "?" if inside is None else f"{100 * inside:.0f} %"
        bad.append(f"{name}: ANEES {e['anees']:.3g}, band [{lo:.3g}, {hi:.3g}] over "
                   f"{e['runs_scored']} runs, {share} of epochs inside (need "
                   f"{100 * min_inside:.0f} %){detail}")
    if bad:
        raise AssertionError(f"NEES out of band on {result.summary['world']} "
                             f"({FIGURES['nees']}): " + "; ".join(bad))


def nis_in_band(result: CampaignResult, filters: Sequence[str] | None = None) -> None:
    """Each filter's Σ NIS / Σ dof over all runs and updates inside its 95 % χ² band; the
    message names the run with the largest NIS per dof and its worst epoch."""
    bad = []
    for name in _filters(result, filters):
        runs = [(o.run, o.scores[name]) for o in result.outcomes if not o.scores[name].diverged]
        nis = [np.asarray(s.nis, dtype=float) for _, s in runs]
        dof = [np.broadcast_to(np.asarray(s.nis_dof, dtype=float), n.shape)
               for n, (_, s) in zip(nis, runs)]
        st = consistency.nis_stats(np.concatenate(nis) if nis else [],
                                   np.concatenate(dof) if dof else [])
        if not st:
            bad.append(f"{name}: no NIS")
            continue
        lo, hi = st["band"]
        if lo <= st["per_dof"] <= hi:
            continue
        ok = [(r, n, d) for (r, _), n, d in zip(runs, nis, dof) if np.isfinite(n).any()]
        r, n, d = max(ok, key=lambda x: np.nansum(x[1]) / np.sum(x[2][np.isfinite(x[1])]))
        k = int(np.nanargmax(n / d))
        epochs = getattr(dict(runs)[r], "nis_epoch", None)
        at = _where(result, int(epochs[k]) if epochs is not None else k)
        bad.append(f"{name}: NIS/dof {st['per_dof']:.3g}, band [{lo:.3g}, {hi:.3g}] over "
                   f"{st['updates']} updates; largest: run {r} (NIS/dof "
                   f"{np.nansum(n) / np.sum(d[np.isfinite(n)]):.3g}), its worst update at {at}")
    if bad:
        raise AssertionError(f"NIS out of band on {result.summary['world']} (the consistency "
                             "figure's NIS panel): " + "; ".join(bad))


def consistent(result: CampaignResult, filters: Sequence[str] | None = None,
               min_inside: float = 0.9) -> None:
    """:func:`nees_in_band` and :func:`nis_in_band`."""
    nees_in_band(result, filters, min_inside)
    nis_in_band(result, filters)


def _metric(result: CampaignResult, metric: str | None) -> str:
    return metric or ERROR_METRICS[result.summary["kind"]]


def _values(v: Any) -> dict[str, float]:
    return {k: float(x) for k, x in v.items()} if isinstance(v, dict) else {"": float(v)}


def error_within(result: CampaignResult, factor: float, metric: str | None = None,
                 filters: Sequence[str] | None = None) -> None:
    """Each filter's ``metric`` (default :data:`ERROR_METRICS` of the kind) at most
    ``factor`` × the smoother's on the same runs."""
    key = _metric(result, metric)
    ref = _values(result.summary["reference"][REFERENCE][key])
    bad = []
    for name in _filters(result, filters):
        mine = _values(result.summary["filters"][name][key])
        for axis, v in mine.items():
            if not v <= factor * ref[axis]:
                bad.append(f"{name}: {key}{'.' + axis if axis else ''} = {v:.4g} is "
                           f"{v / ref[axis]:.3g}× the smoother's {ref[axis]:.4g} "
                           f"(allowed {factor:g}×)")
    if bad:
        raise AssertionError(f"error above {factor:g}× the smoother's on "
                             f"{result.summary['world']} over {result.summary['runs']} runs "
                             f"({FIGURES['error']}): " + "; ".join(bad))


def agrees_with(result: CampaignResult, builtin: str, *, rtol: float = 1e-6,
                atol: float = 0.0, filters: Sequence[str] | None = None) -> None:
    """The filters' per-run errors equal those of the built-in filter ``builtin`` on the
    same world, runs and seed (run without any :func:`substituted` filter) to ``rtol`` /
    ``atol``; the message names the first run and epoch that differ."""
    world = result.world
    base = run(world, [builtin], runs=result.summary["runs"], seed=result.summary["seed"])
    bad = []
    for name in _filters(result, filters):
        for o, b in zip(result.outcomes, base.outcomes):
            mine, theirs = _first(o.scores[name], ERROR_ATTRIBUTES), _first(
                b.scores[builtin], ERROR_ATTRIBUTES)
            if mine is None or theirs is None or mine.shape != theirs.shape:
                bad.append(f"run {o.run}: {name} and {builtin} errors not comparable")
                break
            close = np.isclose(mine, theirs, rtol=rtol, atol=atol, equal_nan=True)
            if not close.all():
                k = int(np.argwhere(~close)[0][0])
                diff = np.nanmax(np.abs(mine[k] - theirs[k]))
                bad.append(f"run {o.run}: {name} differs from {builtin} first at "
                           f"{_where(result, k)} by {diff:.3g}")
                break
    if bad:
        raise AssertionError(f"disagreement on {result.summary['world']} "
                             f"({FIGURES['error']}): " + "; ".join(bad))
