"""SRCKF vs SR-CH∞KF when the measurement noise is larger than the filter assumes.

The [Spin SR-CH∞KF] problem, reduced to what the filters see: state
``[α, β]`` (pitch, yaw, rad) propagated by gyro-derived increments
``X_k = X_{k-1} + u_{k-1} + w`` (eq. 9), measured by the magnetometer's axial component
(eq. 6, normalised by the field intensity)

    B_x / B = cos I cos α cos(D − β) + sin I sin α,   I = −48.17°, D = 2.32°.

Truth: 87.5 s at 0.1 s; pitch follows a ballistic-shaped profile from +45° to −45°
(``tan α = tan 45° · (1 − 2t/T)``), yaw drifts from −10° to −20° with a ±2° oscillation
(a stand-in for the S4 truth world, which is not used here).  The reading depends on yaw
through ``cos(D − β)`` only, so β and 2D − β are indistinguishable; the yaw is kept
away from D so that the filters do not lock onto the mirror branch (with yaw starting
at 0° ≈ D they do, and yaw RMSE then measures branch choice, not robustness).

The gyro increments carry white noise, the magnetometer white noise.  With
``--mismatch measurement`` (default) the magnetometer noise is ``--factor`` (default 5)
times the standard deviation the filters assume; ``--mismatch process`` scales the gyro
noise instead.

Every filter sees the same data in each run (seeded).  For each γ the SR-CH∞KF runs with
``on_failure="kalman"`` and the number of Riccati fallbacks is reported.  Prints one JSON
object::

    {"config": {...}, "rows": [{"filter": "srckf", "gamma": null,
      "rmse_pitch_deg": ..., "rmse_yaw_deg": ..., "nees": ..., "fallbacks": 0}, ...]}

``nees`` is the mean normalised estimation error squared (2 for a consistent filter).
Usage: ``python -m benchmarks.robustness [--runs 100] [--factor 5] [--gammas 5 3 2 1.5 1]
[--mismatch measurement|process]``.
"""

from __future__ import annotations

import benchmarks.single_thread  # noqa: F401  (before numpy: one BLAS thread)

# isort: split
import argparse
import json
import time

import numpy as np

from estimators import Euclidean, Measurement, Noise, Transition
from estimators.filters import make_filter

INC, DEC = np.deg2rad(-48.17), np.deg2rad(2.32)
DT, T_FLIGHT = 0.1, 87.5
SIGMA_GYRO = np.deg2rad(0.05)  # per-step increment noise (rad)
SIGMA_MAG = 0.005              # assumed magnetometer noise (fraction of |B|)
P0 = np.deg2rad(3.0) ** 2 * np.eye(2)
X0_ERROR = np.deg2rad([2.0, -2.0])


def truth() -> np.ndarray:
    t = np.arange(0.0, T_FLIGHT + DT / 2, DT)
    pitch = np.arctan(np.tan(np.pi / 4) * (1.0 - 2.0 * t / T_FLIGHT))
    yaw = -np.deg2rad(10.0 + 10.0 * t / T_FLIGHT) + np.deg2rad(2.0) * np.sin(2 * np.pi * t / 30)
    return np.column_stack([pitch, yaw])


def h(X: np.ndarray) -> np.ndarray:
    a, b = X[:, 0], X[:, 1]
    return (np.cos(INC) * np.cos(a) * np.cos(DEC - b) + np.sin(INC) * np.sin(a))[:, None]


def models() -> tuple[Transition, Measurement]:
    tr = Transition(lambda X, u: X + u, Noise.from_sigmas([SIGMA_GYRO, SIGMA_GYRO]))
    return tr, Measurement(h, Noise.from_sigmas([SIGMA_MAG]))


def simulate(x_true: np.ndarray, factor: float, rng: np.random.Generator,
             mismatch: str = "measurement"):
    """Gyro increments (true increment minus the gyro noise the state absorbs) and readings.

    ``factor`` scales the true noise of the magnetometer (``mismatch="measurement"``) or
    of the gyro (``"process"``) relative to what the filters assume.
    """
    fm, fg = (factor, 1.0) if mismatch == "measurement" else (1.0, factor)
    inc = np.diff(x_true, axis=0)
    us = inc - rng.normal(0.0, fg * SIGMA_GYRO, inc.shape)
    zs = h(x_true[1:]) + rng.normal(0.0, fm * SIGMA_MAG, (len(inc), 1))
    return us, zs


def run_filter(filt, x_true, us, zs):
    tr, me = models()
    b = filt.init(x_true[0] + X0_ERROR, Euclidean(2), cov=P0)
    err = np.empty((len(us), 2))
    nees = np.empty(len(us))
    fallbacks = 0
    for k, (u, z) in enumerate(zip(us, zs)):
        b, inn = filt.update(filt.predict(b, tr, u), me, z)
        fallbacks += inn.hinf_fallback
        e = b.mean - x_true[k + 1]
        err[k] = e
        nees[k] = e @ np.linalg.solve(b.cov, e)
    return err, nees, fallbacks


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--factor", type=float, default=5.0)
    ap.add_argument("--gammas", type=float, nargs="+", default=[5.0, 3.0, 2.0, 1.5, 1.0])
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--mismatch", choices=["measurement", "process"], default="measurement",
                    help="which noise is --factor times larger than assumed")
    args = ap.parse_args(argv)

    x_true = truth()
    filters = [("srckf", None, make_filter("srckf"))] + [
        ("srchinf", g, make_filter("srchinf", gamma=g, on_failure="kalman"))
        for g in args.gammas]
    sq = {i: np.zeros(2) for i in range(len(filters))}
    nees = {i: 0.0 for i in range(len(filters))}
    falls = {i: 0 for i in range(len(filters))}
    per_run = {i: [] for i in range(len(filters))}
    t0 = time.perf_counter()
    for r in range(args.runs):
        us, zs = simulate(x_true, args.factor, np.random.default_rng([args.seed, r]),
                          args.mismatch)
        for i, (_, _, f) in enumerate(filters):
            err, ne, fb = run_filter(f, x_true, us, zs)
            sq[i] += np.sum(err**2, axis=0)
            nees[i] += float(np.sum(ne))
            falls[i] += fb
            per_run[i].append(float(np.sqrt(np.mean(np.sum(err**2, axis=1)))))
    n = args.runs * (len(x_true) - 1)
    base = np.array(per_run[0])
    rows = []
    for i, (name, g, _) in enumerate(filters):
        rmse = np.rad2deg(np.sqrt(sq[i] / n))
        rows.append({
            "filter": name, "gamma": g,
            "rmse_pitch_deg": round(float(rmse[0]), 4),
            "rmse_yaw_deg": round(float(rmse[1]), 4),
            "nees": round(nees[i] / n, 3),
            "fallbacks": falls[i],
            "runs_better_than_srckf": int(np.sum(np.array(per_run[i]) < base)),
        })
    out = {
        "config": {"runs": args.runs, "steps": len(x_true) - 1, "dt": DT,
                   "mismatch": args.mismatch, "noise_factor": args.factor,
                   "assumed_mag_sigma": SIGMA_MAG,
                   "gyro_sigma_deg": float(np.rad2deg(SIGMA_GYRO)), "seed": args.seed,
                   "seconds": round(time.perf_counter() - t0, 1)},
        "rows": rows,
    }
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
