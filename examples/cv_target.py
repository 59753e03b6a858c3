"""A 2-D constant-velocity target seen in range and bearing, filtered by the SRCKF and reported."""
import sys

import numpy as np

from estimators import Euclidean, Measurement, Noise, Transition, Wrapped, make_filter
from slam.arrays import report

dt, q, K, runs = 1.0, 0.05, 100, 20
F = np.kron(np.eye(2), [[1.0, dt], [0.0, 1.0]])  # state [x, vx, y, vy]
Q = q * np.kron(np.eye(2), [[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
P0, R, x0 = np.diag([25.0, 1.0, 25.0, 1.0]), np.diag([1.0, 0.02**2]), np.array([100, 1, 50, -1.0])
def rb(X):  # range and bearing of [x, vx, y, vy] rows
    return np.stack([np.hypot(X[..., 0], X[..., 2]), np.arctan2(X[..., 2], X[..., 0])], -1)
move = Transition(lambda X, u: X @ F.T, Noise.from_cov(Q))
sense = Measurement(rb, Noise.from_cov(R), Wrapped(2, (1,)))
rng, flt = np.random.default_rng(1), make_filter("srckf")
est, cov, truth, inn, S = (np.zeros((runs, K) + s) for s in ((4,), (4, 4), (4,), (2,), (2, 2)))
for r in range(runs):
    x, b = rng.multivariate_normal(x0, P0), flt.init(x0, Euclidean(4), cov=P0)
    for k in range(K):
        x = F @ x + rng.multivariate_normal(np.zeros(4), Q)
        z = rb(x) + rng.multivariate_normal(np.zeros(2), R)
        b, i = flt.update(flt.predict(b, move), sense, z)
        est[r, k], cov[r, k], truth[r, k], inn[r, k], S[r, k] = b.mean, b.cov, x, i.nu, i.cov
summary = report(np.arange(1, K + 1) * dt, {"srckf": est}, {"srckf": cov}, truth=truth,
                 innovations={"srckf": inn}, innovation_covs={"srckf": S}, name="cv-target",
                 labels=("x", "vx", "y", "vy"), units=("m", "m/s", "m", "m/s"),
                 out=sys.argv[1] if len(sys.argv) > 1 else "out/cv-target")
print(summary["filters"]["srckf"]["consistency"], summary["filters"]["srckf"]["anees"])
