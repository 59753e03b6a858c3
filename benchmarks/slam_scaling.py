"""Time per SLAM step against the number of mapped landmarks: ``joint`` vs ``local`` mode.

A step is one filter epoch of Bailey's planar SLAM: a prediction through 8 control steps of
the car model (16 control-noise inputs) and a batch update with 2-4 re-observed landmarks
(range-bearing).  The belief is synthesised, not simulated: the vehicle and ``N`` landmarks
already mapped, with a random valid covariance (a lower-triangular factor from a QR of a
random matrix, vehicle σ ≈ 0.5 m, landmarks σ ≈ 1 m).  Every filter starts each step from
the same belief, so the state size stays ``3 + 2N``.  BLAS is pinned to one thread.

Prints one JSON object::

    {"rows": [{"filter", "mode", "landmarks", "us_per_step"}, ...],
     "exponents": [{"filter", "mode", "exponent"}, ...],      # slope of log t vs log N
     "exponents_135_to_500": [...],                            # the same, last two sizes
     "checks": {...}}

Run: ``python -m benchmarks.slam_scaling`` (well under a minute; joint mode at 500
landmarks is sampled with fewer steps); ``python -m benchmarks.slam_scaling 10 35`` times
only those sizes.  Local mode is the filter's partitioned steps,
``filt.partitioned(layout)`` (:mod:`estimators.partitioned`).
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from estimators import BlockLayout, make_filter
from estimators.linalg import tria
from slam.kinds.planar.models import motion_model, observation_model, range_bearing, state_space

LANDMARKS = (10, 35, 135, 500)
CASES = (("ekf", "joint"), ("ekf", "local"), ("srckf", "joint"), ("srckf", "local"))
CONTROL_COV = np.diag([0.3, np.radians(3.0)]) ** 2
OBS_COV = np.diag([0.1, np.radians(1.0)]) ** 2
EPOCH = 8
#: The planar state: the pose ``[x, y, φ]``, then 2-D landmarks (sizes from the spaces).
LAYOUT = BlockLayout.of(state_space)


def synthetic_belief(filt, n_lm: int, rng: np.random.Generator):
    """Vehicle at the origin, ``n_lm`` landmarks within 100 m, a random valid factor."""
    n = 3 + 2 * n_lm
    mean = np.concatenate([[0.0, 0.0, 0.3], rng.uniform(-100.0, 100.0, 2 * n_lm)])
    scale = np.r_[0.5, 0.5, 0.05, np.full(2 * n_lm, 1.0)]
    S = tria(rng.normal(size=(n, n)) * scale[:, None] / np.sqrt(n))
    S[np.diag_indices(n)] += 0.05 * scale
    return filt.init(mean, state_space(n_lm), sqrt=S)


def steps_for(n_lm: int, mode: str) -> int:
    if mode == "joint" and n_lm >= 500:
        return 2
    if mode == "joint" and n_lm >= 135:
        return 6
    return 30


def time_step(name: str, mode: str, n_lm: int, seed: int = 0) -> float:
    """Median wall time (µs) of predict + update from the synthetic belief."""
    rng = np.random.default_rng(seed)
    filt = make_filter(name)
    b0 = synthetic_belief(filt, n_lm, rng)
    motion = motion_model(0.025, 4.0, CONTROL_COV, EPOCH)
    u = np.tile([3.0, 0.05], (EPOCH, 1))
    n_steps = steps_for(n_lm, mode)
    local = filt.partitioned(LAYOUT) if mode == "local" else None
    cases = []
    for _ in range(n_steps + 1):
        k = int(rng.integers(2, 5))
        slots = rng.choice(n_lm, size=k, replace=False)
        z = range_bearing(b0.mean[None, :], slots)[0] + rng.normal(0.0, 0.05, 2 * k)
        cases.append((slots, z))
    times = []
    for i, (slots, z) in enumerate(cases):
        t0 = time.perf_counter()
        if local is not None:
            b = local.predict(b0, motion, u)
            local.update(b, slots, observation_model(np.arange(len(slots)), OBS_COV), z)
        else:
            b = filt.predict(b0, motion, u)
            filt.update(b, observation_model(slots, OBS_COV), z)
        if i:  # the first step warms caches up
            times.append(time.perf_counter() - t0)
    return 1e6 * float(np.median(times))


def main(landmarks: tuple[int, ...] = LANDMARKS) -> dict:
    """Time every case at every size in ``landmarks``; print and return the JSON dict."""
    from threadpoolctl import threadpool_limits

    rows = []
    with threadpool_limits(1):
        for name, mode in CASES:
            for n_lm in landmarks:
                us = time_step(name, mode, n_lm)
                rows.append({"filter": name, "mode": mode, "landmarks": n_lm,
                             "us_per_step": round(us, 1)})
                print(f"{name:6s} {mode:6s} {n_lm:4d} {us:12.1f} us", file=sys.stderr)
    exponents, tail = [], []
    for name, mode in CASES:
        r = [row for row in rows if row["filter"] == name and row["mode"] == mode]
        logn = np.log([x["landmarks"] for x in r])
        logt = np.log([x["us_per_step"] for x in r])
        slope = np.polyfit(logn, logt, 1)[0]
        exponents.append({"filter": name, "mode": mode, "exponent": round(float(slope), 3)})
        tail.append({"filter": name, "mode": mode,
                     "exponent": round(float((logt[-1] - logt[-2]) / (logn[-1] - logn[-2])), 3)})

    def us(name: str, mode: str, n: int) -> float:
        return next(x["us_per_step"] for x in rows
                    if x["filter"] == name and x["mode"] == mode and x["landmarks"] == n)

    exp_local = next(e["exponent"] for e in exponents
                     if e["filter"] == "srckf" and e["mode"] == "local")
    checks = {
        "srckf_local_exponent_at_most_2.2": exp_local <= 2.2,
        "srckf_local_faster_than_joint_from_35": all(
            us("srckf", "local", n) < us("srckf", "joint", n) for n in landmarks if n >= 35),
    }
    out = {"rows": rows, "exponents": exponents, "exponents_135_to_500": tail, "checks": checks}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or LANDMARKS)
