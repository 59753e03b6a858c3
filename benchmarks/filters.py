"""Time one predict + update of every filter on a planar-SLAM-like model.

The state is a pose ``[x, y, φ]`` (plus a speed-scale factor when needed to reach
the size) and ``N`` landmarks; unicycle motion with additive noise; one range-bearing
observation per step of a landmark placed so that bearings cross ±π.  filterpy's
``UnscentedKalmanFilter`` runs the exact same problem in the same process, with its
angle-aware mean and residual functions.  Prints one JSON object::

    {"rows": [{"filter": "srckf", "n": 23, "us_per_step": 210.5}, ...],
     "ratios": {"filterpy-ukf / srckf at n=23": 8.7}}

Usage: ``python -m benchmarks.filters [--steps 300] [--sizes 6 23 63]``.
"""

from __future__ import annotations

import benchmarks.single_thread  # noqa: F401  (before numpy: one BLAS thread)

# isort: split
import argparse
import json
import math
import time

import numpy as np

from estimators import (
    FILTER_NAMES,
    Measurement,
    Noise,
    Transition,
    Wrapped,
    make_filter,
    wrap_angle,
)

DT, SPEED, TURN = 0.1, 3.0, 0.25


def problem(n: int):
    """Models and the landmark layout for an ``n``-dimensional state."""
    n_lm = (n - 3) // 2
    scale = (n - 3) % 2 == 1  # a speed-scale state fills an odd remainder
    off = 4 if scale else 3
    ang = np.linspace(0.0, 2 * np.pi, n_lm, endpoint=False)
    landmarks = np.column_stack([8.0 * np.cos(ang), 8.0 * np.sin(ang)])

    def f(X, u):
        s = X[:, 3] if scale else 1.0
        Y = X.copy()
        Y[:, 0] += DT * SPEED * s * np.cos(X[:, 2])
        Y[:, 1] += DT * SPEED * s * np.sin(X[:, 2])
        Y[:, 2] = wrap_angle(X[:, 2] + DT * TURN)
        return Y

    q = np.full(n, 1e-8)
    q[:3] = [1e-3, 1e-3, 1e-4]
    if scale:
        q[3] = 1e-5
    tr = Transition(f, Noise.from_cov(np.diag(q)))

    def measurement(j: int) -> Measurement:
        def h(X):
            dx = X[:, off + 2 * j] - X[:, 0]
            dy = X[:, off + 2 * j + 1] - X[:, 1]
            return np.column_stack([np.hypot(dx, dy), wrap_angle(np.arctan2(dy, dx) - X[:, 2])])
        return Measurement(h, Noise.from_cov(np.diag([0.01, 3e-4])), space=Wrapped(2, (1,)))

    x0 = np.zeros(n)
    x0[2] = np.pi - 0.05
    if scale:
        x0[3] = 1.0
    x0[off:] = landmarks.ravel()
    space = Wrapped(n, (2,))
    return tr, measurement, x0, space, n_lm


def observations(tr, measurement, x0, n_lm, steps, rng):
    x = x0[None, :]
    zs = []
    for k in range(steps):
        x = tr.f(x, None)
        j = k % n_lm
        z = measurement(j).h(x)[0] + rng.normal(0.0, [0.1, 0.017])
        zs.append((j, np.array([z[0], wrap_angle(z[1])])))
    return zs


def time_filter(name, tr, measurement, x0, space, zs, P0):
    f = make_filter(name)
    b = f.init(x0, space, cov=P0)
    models = {}
    times = []
    for j, z in zs:
        me = models.setdefault(j, measurement(j))
        t0 = time.perf_counter()
        b = f.predict(b, tr)
        b, _ = f.update(b, me, z)
        times.append(time.perf_counter() - t0)
    return float(np.median(times) * 1e6)


def time_filterpy(tr, measurement, x0, zs, P0, n):
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    def x_mean(sigmas, Wm):
        x = Wm @ sigmas
        x[2] = np.arctan2(Wm @ np.sin(sigmas[:, 2]), Wm @ np.cos(sigmas[:, 2]))
        return x

    def z_mean(sigmas, Wm):
        return np.array([Wm @ sigmas[:, 0],
                         np.arctan2(Wm @ np.sin(sigmas[:, 1]), Wm @ np.cos(sigmas[:, 1]))])

    # filterpy calls the residuals once per sigma point on scalars: wrap with float
    # arithmetic, so filterpy is not charged for numpy's per-call overhead
    def wrap(a: float) -> float:
        return (a + math.pi) % (2.0 * math.pi) - math.pi

    def resid_x(a, b):
        d = a - b
        d[2] = wrap(d[2])
        return d

    def resid_z(a, b):
        d = a - b
        d[1] = wrap(d[1])
        return d

    pts = MerweScaledSigmaPoints(n, alpha=1.0, beta=2.0, kappa=0.0, subtract=resid_x)
    ukf = UnscentedKalmanFilter(dim_x=n, dim_z=2, dt=DT, points=pts,
                                fx=lambda x, dt: tr.f(x[None, :], None)[0], hx=None,
                                x_mean_fn=x_mean, z_mean_fn=z_mean,
                                residual_x=resid_x, residual_z=resid_z)
    ukf.x, ukf.P, ukf.Q = x0.copy(), P0.copy(), tr.noise.cov.copy()
    ukf.R = measurement(0).noise.cov.copy()
    hx = {j: (lambda m: (lambda x: m.h(x[None, :])[0]))(measurement(j)) for j in set(
        j for j, _ in zs)}
    times = []
    for j, z in zs:
        t0 = time.perf_counter()
        ukf.predict()
        ukf.update(z, hx=hx[j])
        times.append(time.perf_counter() - t0)
    return float(np.median(times) * 1e6)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--sizes", type=int, nargs="+", default=[6, 23, 63])
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    rows = []
    for n in args.sizes:
        tr, measurement, x0, space, n_lm = problem(n)
        zs = observations(tr, measurement, x0, n_lm, args.steps, rng)
        P0 = np.diag(np.r_[[0.1, 0.1, 0.01], np.full(n - 3, 0.05)])
        for name in FILTER_NAMES:
            rows.append({"filter": name, "n": n,
                         "us_per_step": round(time_filter(name, tr, measurement, x0, space,
                                                          zs, P0), 1)})
        rows.append({"filter": "filterpy-ukf", "n": n,
                     "us_per_step": round(time_filterpy(tr, measurement, x0, zs, P0, n), 1)})
    by = {(r["filter"], r["n"]): r["us_per_step"] for r in rows}
    ratios = {f"filterpy-ukf / {name} at n={n}": round(by[("filterpy-ukf", n)] / by[(name, n)],
                                                         2)
              for n in args.sizes for name in ("srckf", "ukf")}
    print(json.dumps({"rows": rows, "ratios": ratios}, indent=1))


if __name__ == "__main__":
    main()
