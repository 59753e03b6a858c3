r"""The noise-mismatch sweep: how each filter's pitch and yaw RMSE grow when the true
noise is a factor times what the filters assume, and how often the H∞ existence check
fails ([Spin SR-CH∞KF]'s "measurement noise uncertainty" case).

The sweep's cells are (distribution, factor); a cell gets ``runs_per_cell`` logs.  Log
``t`` (:func:`cell_of`) simulates the world's flight with the true noise of its cell
(:mod:`slam.kinds.spinning.noise`: ``f`` times the assumed σ on the sensors ``[sweep]
scale`` names) and runs every sweep filter on it, the H∞ filters once per γ, all from the
same prior draw: the comparison between filters is paired.  An H∞ filter at
:math:`\gamma = \infty` *is* its Kalman twin (``srchinf`` -> ``srckf``, ``uthinf`` ->
``ukf``; :mod:`estimators.hinf`, and a test on this model to 1e-9), so when the twin is
in the sweep its row is reused instead of run again.

H∞ filters run with ``on_failure="kalman"``: an update whose Riccati condition (eq.
25/33) fails is the Kalman update for that step and is counted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from estimators import wrap_angle
from slam.kinds.spinning.models import run_filter, world_models
from slam.kinds.spinning.simulate import SimConfig, simulate

Array = NDArray[np.float64]

TWINS = {"srchinf": "srckf", "uthinf": "ukf"}
"""Each H∞ filter's Kalman twin (its γ = ∞ limit)."""


@dataclass(frozen=True)
class SweepCell:
    """One filter (at one γ) on one sweep log: summed squared pitch and yaw errors (rad²)
    over ``n`` epochs, H∞ existence failures among ``updates``, and whether it diverged."""

    sq: tuple[float, float]
    n: int
    fallbacks: int
    updates: int
    diverged: bool


@dataclass(frozen=True)
class SweepRecord:
    """One sweep log: its cell (distribution, factor), replicate, and the rows by label."""

    distribution: str
    factor: float
    replicate: int
    rows: dict[str, SweepCell]


def label(name: str, gamma: float | None) -> str:
    """``"srckf"`` or ``"srchinf γ=2"`` (``γ=∞`` for the Kalman limit)."""
    if gamma is None:
        return name
    return f"{name} γ={'∞' if math.isinf(gamma) else format(gamma, 'g')}"


def sweep_rows(spec: Any) -> list[tuple[str, str, float | None]]:
    """``(label, filter, γ)`` of every sweep row, in table order (H∞ rows per γ)."""
    rows: list[tuple[str, str, float | None]] = []
    for name in spec.filters:
        if name in TWINS:
            rows += [(label(name, g), name, g) for g in spec.gammas_rad]
        else:
            rows.append((name, name, None))
    return rows


def cell_of(spec: Any, t: int) -> tuple[str, float, int]:
    """Sweep log ``t`` -> (distribution, factor, replicate): cells cycle fastest, so a
    partial sweep (fewer campaign runs than logs) still covers every cell once first."""
    n_cells = len(spec.distributions) * len(spec.factors)
    cell, replicate = t % n_cells, t // n_cells
    return (spec.distributions[cell // len(spec.factors)],
            spec.factors[cell % len(spec.factors)], replicate)


def _cell(err: Array, fallbacks: int, updates: int, diverged: bool) -> SweepCell:
    e = err[np.all(np.isfinite(err), axis=1)]
    sq = np.sum(e**2, axis=0)
    return SweepCell((float(sq[0]), float(sq[1])), len(e), fallbacks, updates, diverged)


def sweep_task(world: Any, cfg: SimConfig, t: int, rng: np.random.Generator) -> SweepRecord:
    """Simulate sweep log ``t`` and run every sweep row on it (module docstring)."""
    spec = world.sweep
    dist, factor, replicate = cell_of(spec, t)
    scale = {"both": (factor, factor), "magnetometer": (factor, 1.0),
             "gyro": (1.0, factor)}[spec.scale]
    log = simulate(cfg.with_noise(distribution=dist, magnetometer_factor=scale[0],
                                  gyro_factor=scale[1]), rng)
    base = world_models(world, log, rng)
    rows: dict[str, SweepCell] = {}
    for lab, name, gamma in sweep_rows(spec):
        twin = TWINS.get(name)
        if gamma is not None and math.isinf(gamma) and twin in spec.filters:
            continue  # filled from the twin below
        m = replace(base, gamma=math.inf if gamma is None else gamma, on_failure="kalman")
        s = run_filter(log, name, m)
        final = np.abs(wrap_angle(s.means[-1] - log.truth[-1]))
        diverged = s.diverged or not bool(np.all(final <= world.scoring.divergence_rad))
        rows[lab] = _cell(wrap_angle(s.means - log.truth), s.fallbacks, s.updates, diverged)
    for lab, name, _ in sweep_rows(spec):
        if lab not in rows:
            rows[lab] = rows[TWINS[name]]
    return SweepRecord(dist, factor, replicate, rows)


def _finite(gamma: float | None) -> float | None:
    """γ as JSON holds it: ``None`` for no γ or γ = ∞ (the row's label says which)."""
    return None if gamma is None or math.isinf(gamma) else gamma


def _no_gamma(name: str, gamma: float | None) -> str:
    """Why a sweep row's ``gamma_rad`` is null."""
    if gamma is None:
        return f"{name} is a Kalman filter: no H∞ bound"
    return "γ = ∞, the Kalman limit (strict JSON has no infinity)"


def summarize_sweep(spec: Any, records: list[SweepRecord]) -> dict[str, Any]:
    """``summary.json``'s ``sweep``: per distribution, factor and row, the pitch and yaw
    RMSE (deg) over the logs where the row did not diverge, the H∞ existence failures
    and updates, and the diverged logs; ``epochs`` the epochs the RMSE is over (0: no log
    left, the RMSE null).  ``gamma_rad`` is ``None`` for the Kalman filters and for γ = ∞
    (strict JSON has no infinity), with ``gamma_rad_reason``."""
    cells: list[dict[str, Any]] = []
    for dist in spec.distributions:
        for factor in spec.factors:
            mine = [r for r in records if r.distribution == dist and r.factor == factor]
            for lab, name, gamma in sweep_rows(spec):
                got = [r.rows[lab] for r in mine if lab in r.rows]
                good = [c for c in got if not c.diverged]
                n = sum(c.n for c in good)
                sq = np.sum([c.sq for c in good], axis=0) if good else np.full(2, np.nan)
                rmse = np.degrees(np.sqrt(sq / n)) if n else np.full(2, np.nan)
                cell = {
                    "distribution": dist, "factor": factor, "row": lab, "filter": name,
                    "gamma_rad": _finite(gamma), "logs": len(got),
                    "diverged": sum(c.diverged for c in got), "epochs": int(n),
                    "rmse_pitch_deg": float(rmse[0]), "rmse_yaw_deg": float(rmse[1]),
                    "fallbacks": sum(c.fallbacks for c in got),
                    "updates": sum(c.updates for c in got)}
                if _finite(gamma) is None:
                    cell["gamma_rad_reason"] = _no_gamma(name, gamma)
                cells.append(cell)
    out = {"factors": list(spec.factors), "gammas_rad": [_finite(g) for g in spec.gammas_rad]}
    if None in out["gammas_rad"]:
        out["gammas_rad_reason"] = _no_gamma("", math.inf)
    return {**out, "distributions": list(spec.distributions), "scale": spec.scale,
            "runs_per_cell": spec.runs_per_cell, "logs_done": len(records),
            "rows": [lab for lab, _, _ in sweep_rows(spec)], "cells": cells}
