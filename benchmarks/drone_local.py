r"""Time per drone SLAM epoch: ``joint`` vs ``local`` (partitioned) mode, SRCKF and EKF.

The drone's quaternion SINS/SLAM models (:mod:`slam.kinds.drone.models`): vehicle
``[p, v, q, b_g, b_a]`` (ambient 16, tangent 15), 3-D landmarks.  One epoch is

* a prediction through ``IMU_SAMPLES`` IMU samples (:func:`imu_transition`: every sigma
  point mechanised through every sample, additive tangent noise :math:`Q`),
* a batch update with 3-5 re-observed landmarks (range/azimuth/elevation), and
* the augmentation with one new landmark (inverse observation, noise as an input).

Local mode is the filter's partitioned steps on ``BlockLayout.of(state_space)``
(:mod:`estimators.partitioned`): the prediction draws :math:`2\cdot 15` cubature points
over the vehicle instead of :math:`2(15 + 3N)` over the joint state, the update
:math:`2(15 + 3k)`, the augmentation :math:`2(15 + 3)`; the joint factor is changed by
rank-:math:`k` Cholesky updates.  The belief is synthesised, not simulated: the drone
hovering at 20 m, ``N`` landmarks within 60 m, a random valid factor (vehicle position
σ ≈ 0.5 m, attitude σ ≈ 0.01 rad, landmarks σ ≈ 1 m).  Every epoch starts from that
belief, so the state stays at ``15 + 3N``; one run, BLAS pinned to one thread.

Prints one JSON object::

    {"landmarks": N, "state_dim": 15 + 3N, "imu_samples": 10,
     "rows": [{"filter", "mode", "us_per_epoch"}, ...],
     "joint_over_local": {"srckf": ..., "ekf": ...},
     "max_abs_diff_first_epoch": {"srckf": ..., "ekf": ...},   # local vs joint, mean and P
     "checks": {"ekf_local_equals_joint": bool}}

The EKF's local epoch equals its joint one to rounding; the SRCKF's differs (joint mode
spreads the cubature points by :math:`\sqrt{15 + 3N}`, local mode by the block's
dimension; centimetres here, see :mod:`estimators.partitioned`).

Run: ``python -m benchmarks.drone_local [N]`` (default ``N = 100``; well under a minute).
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

import numpy as np

from estimators import BlockLayout, make_filter
from estimators.linalg import tria
from estimators.models import Belief
from nav.quaternion import qexp
from slam.kinds.drone.models import (
    VEH_AMBIENT,
    VEH_DIM,
    ImuNoise,
    NavFrame,
    augmentation_model,
    imu_transition,
    observation_model,
    rae,
    state_space,
)

LANDMARKS = 100
IMU_SAMPLES = 10
EPOCHS = {"local": 40, "joint": 8}
FILTERS = ("srckf", "ekf")
LAYOUT = BlockLayout.of(state_space)
NAV = NavFrame(dt=0.01, gravity=np.array([0.0, 0.0, -9.81]))
NOISE = ImuNoise(gyro_arw=3e-3, accel_vrw=3e-2, gyro_bias_rw=1e-4, accel_bias_rw=1e-3)
OBS_COV = np.diag([0.2, np.radians(0.5), np.radians(0.5)]) ** 2


def synthetic_belief(filt: Any, n_lm: int, rng: np.random.Generator) -> Belief:
    """Hovering at 20 m, ``n_lm`` landmarks within 60 m on the ground, a random factor."""
    x = np.concatenate([[0.0, 0.0, 20.0], [1.0, 0.5, 0.0], qexp(np.array([0.0, 0.0, 0.3])),
                        np.zeros(6), np.column_stack([rng.uniform(-60.0, 60.0, (n_lm, 2)),
                                                      rng.uniform(-2.0, 2.0, n_lm)]).ravel()])
    n = VEH_DIM + 3 * n_lm
    scale = np.r_[np.full(3, 0.5), np.full(3, 0.1), np.full(3, 0.01), np.full(3, 1e-4),
                  np.full(3, 1e-2), np.full(3 * n_lm, 1.0)]
    S = tria(rng.normal(size=(n, n)) * scale[:, None] / np.sqrt(n))
    S[np.diag_indices(n)] += 0.05 * scale
    return filt.init(x, state_space(n_lm), sqrt=S)


def epoch_inputs(b0: Belief, n_lm: int, rng: np.random.Generator, count: int) -> list[tuple]:
    """Per epoch: IMU samples, the re-observed slots and their observations, one new one."""
    out = []
    for _ in range(count):
        gyro = np.array([0.01, -0.02, 0.05]) + 1e-3 * rng.normal(size=(IMU_SAMPLES, 3))
        accel = np.array([0.1, 0.0, 9.81]) + 1e-2 * rng.normal(size=(IMU_SAMPLES, 3))
        slots = rng.choice(n_lm, size=int(rng.integers(3, 6)), replace=False)
        z = rae(b0.mean[None, :], slots)[0] + rng.normal(0.0, 0.01, 3 * len(slots))
        z_new = np.array([30.0, 0.4, -0.5])
        out.append(((gyro, accel), slots, z, z_new))
    return out


def epoch(filt: Any, mode: str, b0: Belief, n_lm: int, inputs: tuple) -> Belief:
    """One predict + update + augment from ``b0``; returns the final belief."""
    u, slots, z, z_new = inputs
    if mode == "local":
        steps = filt.partitioned(LAYOUT)
        b = steps.predict(b0, imu_transition(b0.mean[:VEH_AMBIENT], 0, *u, NAV, NOISE), u)
        b, _ = steps.update(b, slots, observation_model(np.arange(len(slots)), OBS_COV), z)
        return steps.augment(b, augmentation_model(0, z_new, OBS_COV), z_new)
    b = filt.predict(b0, imu_transition(b0.mean, n_lm, *u, NAV, NOISE), u)
    b, _ = filt.update(b, observation_model(slots, OBS_COV), z)
    return filt.predict(b, augmentation_model(n_lm, z_new, OBS_COV), z_new)


def time_epochs(name: str, mode: str, n_lm: int, seed: int = 0) -> tuple[float, Belief]:
    """Median wall time (µs) of an epoch, and the first epoch's result."""
    rng = np.random.default_rng(seed)
    filt = make_filter(name)
    b0 = synthetic_belief(filt, n_lm, rng)
    cases = epoch_inputs(b0, n_lm, rng, EPOCHS[mode] + 1)
    times, first = [], None
    for i, inputs in enumerate(cases):
        t0 = time.perf_counter()
        b = epoch(filt, mode, b0, n_lm, inputs)
        if i:  # the first epoch warms caches up
            times.append(time.perf_counter() - t0)
        else:
            first = b
    return 1e6 * float(np.median(times)), first


def main(n_lm: int = LANDMARKS) -> dict:
    """Time both filters in both modes at ``n_lm`` landmarks; print and return the JSON."""
    from threadpoolctl import threadpool_limits

    rows, first = [], {}
    with threadpool_limits(1):
        for name in FILTERS:
            for mode in ("joint", "local"):
                us, first[name, mode] = time_epochs(name, mode, n_lm)
                rows.append({"filter": name, "mode": mode, "us_per_epoch": round(us, 1)})
                print(f"{name:6s} {mode:6s} {n_lm:4d} {us:12.1f} us", file=sys.stderr)

    def us(name: str, mode: str) -> float:
        return next(r["us_per_epoch"] for r in rows if r["filter"] == name and r["mode"] == mode)

    def gap(name: str) -> float:
        lo, jo = first[name, "local"], first[name, "joint"]
        return float(max(np.abs(lo.mean - jo.mean).max(), np.abs(lo.cov - jo.cov).max()))

    out = {
        "landmarks": n_lm, "state_dim": VEH_DIM + 3 * n_lm, "imu_samples": IMU_SAMPLES,
        "rows": rows,
        "joint_over_local": {name: round(us(name, "joint") / us(name, "local"), 2)
                             for name in FILTERS},
        "max_abs_diff_first_epoch": {name: float(f"{gap(name):.3g}") for name in FILTERS},
        "checks": {"ekf_local_equals_joint": gap("ekf") < 1e-8},
    }
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else LANDMARKS)
