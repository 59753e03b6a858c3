r"""The noise-mismatch sweeps: how each filter's pitch and yaw RMSE grow when the true
noise is a factor times what the filters assume, and how often the H∞ existence check
fails ([Spin SR-CH∞KF]'s "measurement noise uncertainty" case).

Three mismatches (``[sweep] scales``): ``"both"`` scales the gyro and the magnetometer
noise together, which leaves the Kalman gain unchanged (only the prior is then relatively
smaller): the weakest test; ``"gyro"`` alone makes the filters trust the gyro too much,
``"magnetometer"`` alone the magnetometer (and, through eq. 7-8, the roll).

The sweep's cells are (scale, distribution, factor); a cell gets ``runs_per_cell`` logs.
Log ``t`` (:func:`cell_of`) simulates the world's flight with the true noise of its cell
(:mod:`slam.kinds.spinning.noise`: ``f`` times the assumed σ on the sensors its scale
names) and runs every sweep filter on it, the H∞ filters once per γ, all from the same
prior draw: the comparison between filters is paired.  An H∞ filter at
:math:`\gamma = \infty` *is* its Kalman twin (``srchinf`` -> ``srckf``, ``uthinf`` ->
``ukf``; :mod:`estimators.hinf`, and a test on this model to 1e-9), so when the twin is
in the sweep its row is reused instead of run again.

H∞ filters run with ``on_failure="kalman"``: an update whose Riccati condition (eq.
25/33) fails is the Kalman update for that step and is counted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
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
    """One sweep log: its cell (scale, distribution, factor), replicate, and the rows by
    label."""

    scale: str
    distribution: str
    factor: float
    replicate: int
    rows: dict[str, SweepCell]


SCALED = {"both": (True, True), "magnetometer": (True, False), "gyro": (False, True)}
"""Which sensors (magnetometer, gyro) a sweep scale multiplies by the factor."""


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


def cells(spec: Any) -> list[tuple[str, str, float]]:
    """Every (scale, distribution, factor) cell, in table order."""
    return [(sc, d, f) for sc in spec.scales for d in spec.distributions for f in spec.factors]


def cell_of(spec: Any, t: int) -> tuple[str, str, float, int]:
    """Sweep log ``t`` -> (scale, distribution, factor, replicate): cells cycle fastest, so
    a partial sweep (fewer campaign runs than logs) still covers every cell once first."""
    every = cells(spec)
    return (*every[t % len(every)], t // len(every))


def _cell(err: Array, fallbacks: int, updates: int, diverged: bool) -> SweepCell:
    e = err[np.all(np.isfinite(err), axis=1)]
    sq = np.sum(e**2, axis=0)
    return SweepCell((float(sq[0]), float(sq[1])), len(e), fallbacks, updates, diverged)


def sweep_task(world: Any, cfg: SimConfig, t: int, rng: np.random.Generator) -> SweepRecord:
    """Simulate sweep log ``t`` and run every sweep row on it (module docstring)."""
    spec = world.sweep
    scale, dist, factor, replicate = cell_of(spec, t)
    mag, gyro = (factor if on else 1.0 for on in SCALED[scale])
    log = simulate(cfg.with_noise(distribution=dist, magnetometer_factor=mag,
                                  gyro_factor=gyro), rng)
    base = world_models(world, log, rng)
    rows: dict[str, SweepCell] = {}
    for lab, name, gamma in sweep_rows(spec):
        twin = TWINS.get(name)
        if gamma is not None and math.isinf(gamma) and twin in spec.filters:
            continue  # filled from the twin below
        m = base if gamma is None else base.with_settings(name, gamma=gamma,
                                                            on_failure="kalman")
        s = run_filter(log, name, m)
        final = np.abs(wrap_angle(s.means[-1] - log.truth[-1]))
        diverged = s.diverged or not bool(np.all(final <= world.scoring.divergence_rad))
        rows[lab] = _cell(wrap_angle(s.means - log.truth), s.fallbacks, s.updates, diverged)
    for lab, name, _ in sweep_rows(spec):
        if lab not in rows:
            rows[lab] = rows[TWINS[name]]
    return SweepRecord(scale, dist, factor, replicate, rows)


def _finite(gamma: float | None) -> float | None:
    """γ as JSON holds it: ``None`` for no γ or γ = ∞ (the row's label says which)."""
    return None if gamma is None or math.isinf(gamma) else gamma


def _no_gamma(name: str, gamma: float | None) -> str:
    """Why a sweep row's ``gamma_rad`` is null."""
    if gamma is None:
        return f"{name} is a Kalman filter: no H∞ bound"
    return "γ = ∞, the Kalman limit (strict JSON has no infinity)"


def summarize_sweep(spec: Any, records: list[SweepRecord]) -> dict[str, Any]:
    """``summary.json``'s ``sweep``: per scale, distribution, factor and row, the pitch and
    yaw RMSE (deg) over the cell's logs that *every* row finished (``paired_logs``: the
    rows are compared on the same logs), the H∞ existence failures and updates over all
    its ``logs``, and the logs the row diverged on.  ``gamma_rad`` is ``None`` for the
    Kalman filters and for γ = ∞ (strict JSON has no infinity), with ``gamma_rad_reason``;
    ``epochs`` the epochs the RMSE is over (0: no paired log left, the RMSE null)."""
    out: list[dict[str, Any]] = []
    labels = [lab for lab, _, _ in sweep_rows(spec)]
    for scale, dist, factor in cells(spec):
        mine = [r for r in records
                if (r.scale, r.distribution, r.factor) == (scale, dist, factor)]
        paired = [r for r in mine if all(lab in r.rows and not r.rows[lab].diverged
                                         for lab in labels)]
        for lab, name, gamma in sweep_rows(spec):
            got = [r.rows[lab] for r in mine if lab in r.rows]
            good = [r.rows[lab] for r in paired]
            n = sum(c.n for c in good)
            sq = np.sum([c.sq for c in good], axis=0) if good else np.full(2, np.nan)
            rmse = np.degrees(np.sqrt(sq / n)) if n else np.full(2, np.nan)
            cell = {
                "scale": scale, "distribution": dist, "factor": factor, "row": lab,
                "filter": name, "gamma_rad": _finite(gamma), "logs": len(got),
                "paired_logs": len(paired), "diverged": sum(c.diverged for c in got),
                "epochs": int(n),
                "rmse_pitch_deg": float(rmse[0]), "rmse_yaw_deg": float(rmse[1]),
                "fallbacks": sum(c.fallbacks for c in got),
                "updates": sum(c.updates for c in got)}
            if _finite(gamma) is None:
                cell["gamma_rad_reason"] = _no_gamma(name, gamma)
            out.append(cell)
    head = {"factors": list(spec.factors), "gammas_rad": [_finite(g) for g in spec.gammas_rad]}
    if None in head["gammas_rad"]:
        head["gammas_rad_reason"] = _no_gamma("", math.inf)
    return {**head, "distributions": list(spec.distributions), "scales": list(spec.scales),
            "runs_per_cell": spec.runs_per_cell, "logs_done": len(records),
            "rows": labels, "cells": out}
