r"""Attitude and gyro bias from GTSAM's EqF data set with the SRCKF and the MEKF.

The same through the workbench in one line, with the GTSAM AHRS smoother, the report and
the figures: ``slam run --log eqf`` (:mod:`slam.kinds.attitude_log`; it gives the numbers
below to 0.001°).  This script shows the library calls it makes.

``EqFdata.csv`` (bundled with GTSAM; 60 s at 200 Hz) holds per row the true attitude
``q`` and gyro bias ``b``, the gyro reading ``w`` with its noise densities ``std_w``
(rad/√s) and ``std_b`` (rad/s/√s), and two direction sensors: ``y_0`` (every 3rd row,
σ = 0.2) reads the fixed reference ``d_0`` through a mounting rotation ``cq_0``,
:math:`y_0 = C(cq_0)^\top C(q)^\top d_0`; ``y_1`` (every 13th row, σ = 0.1) reads ``d_1``.
GTSAM's ABC equivariant filter estimates ``cq_0`` (a 38° rotation) online, starting from
identity; here it is read from the file (known calibration), so the state is ``[q, b]``
and the problem is easier.

Start as GTSAM's ABC EqF example: identity attitude (0.19° from the truth at t = 0), zero
bias (0.0091 rad/s from the truth), P0 = diag(0.1 I3 rad², 0.01 I3 rad²/s²).  Filter noise
is the file's stated noise, untuned.  Row k's gyro reading covers (t_{k-1}, t_k], as in
GTSAM's example.  Errors are |Log(q̂* ⊗ q)| at the measurement rows and at the last row
(t = 60 s, where GTSAM's example reports its final error).  Over the last three rows
(t > 59.985 s) the truth spins up to 27 rad/s and the gyro readings disagree with it by
4.1° (0.01° over the seven rows before), so ``before_tail_deg``, the error at the last
update before them (t = 59.98 s), is also reported.
"""

import functools
import time

import gtsam
import numpy as np

from estimators import Euclidean, Product, make_filter
from estimators.threads import single_thread_blas
from nav import UnitQuaternion, qrotate
from nav.gyro import interval_transition
from nav.observations import direction_measurement

QUAT = UnitQuaternion()
TAIL_START_S = 59.985  # the gyro readings after this disagree with the truth (docstring)


def cols(D: dict[str, np.ndarray], pattern: str, axes: str = "xyz") -> np.ndarray:
    """Columns ``pattern.format(a)`` for ``a`` in ``axes``, side by side."""
    return np.column_stack([D[pattern.format(a)] for a in axes])


def run(filter_name: str, max_seconds: float = np.inf) -> dict:
    """Filter the rows with t <= ``max_seconds``; attitude errors in degrees."""
    path = gtsam.findExampleDataFile("EqFdata.csv")
    A = np.loadtxt(path, delimiter=",", skiprows=1)
    with open(path) as f:  # the header names the columns
        D = dict(zip(f.readline().strip().split(","), A[A[:, 0] <= max_seconds].T))
    t, q_true, gyro = D["t"], cols(D, "q_{}", "wxyz"), cols(D, "w_{}")
    y0_body = qrotate(cols(D, "cq_{}_0", "wxyz"), cols(D, "y_{}_0"))  # known calibration
    Y = np.stack([y0_body, cols(D, "y_{}_1")], axis=1)  # (N, 2, 3) body-frame readings
    R = np.stack([cols(D, "d_{}_0"), cols(D, "d_{}_1")], axis=1)  # their references
    S = np.stack([cols(D, "std_y_{}_0"), cols(D, "std_y_{}_1")], axis=1)  # per-axis sigma
    seen = ~np.isnan(Y[:, :, 0]) & ~np.isnan(R[:, :, 0])
    epochs = np.union1d(np.flatnonzero(seen.any(axis=1)), [len(t) - 1])
    dt, arw, bias_rw = t[1] - t[0], cols(D, "std_w_{}")[0], cols(D, "std_b_{}")[0]
    transition = functools.cache(lambda n: interval_transition(n, dt, arw, bias_rw))
    flt = make_filter(filter_name)
    belief = flt.init(np.r_[1.0, 0, 0, 0, 0, 0, 0], Product([QUAT, Euclidean(3)]),
                      cov=np.diag([0.1] * 3 + [0.01] * 3))
    errors, prev, start = [], 0, time.process_time()
    with single_thread_blas():
        for k in epochs:  # predict over rows prev+1..k, then update with row k's readings
            belief = flt.predict(belief, transition(k - prev), gyro[prev + 1:k + 1])
            if seen[k].any():
                meas = direction_measurement(R[k][seen[k]], S[k][seen[k]])
                belief, _ = flt.update(belief, meas, Y[k][seen[k]].ravel())
            errors.append(QUAT.local(belief.mean[:4], q_true[k]))
            prev = k
    err, te = np.degrees(np.linalg.norm(errors, axis=1)), t[epochs]
    return {"rms_after_10s_deg": np.sqrt(np.mean(err[te >= 10] ** 2)), "final_deg": err[-1],
            "before_tail_deg": err[te <= TAIL_START_S][-1], "final_t_s": te[-1],
            "cpu_s": time.process_time() - start, "t_s": te, "errors_deg": err}


if __name__ == "__main__":
    print("filter  RMS after 10 s  before tail (59.98 s)  final (60 s)   CPU")
    for name in ("srckf", "ekf"):
        r = run(name)
        print(f"{name:6} {r['rms_after_10s_deg']:12.3f} ° {r['before_tail_deg']:18.3f} ° "
              f"{r['final_deg']:12.3f} ° {r['cpu_s']:5.1f} s")
    print("GTSAM's ABC EqF example (calibration estimated online): final 3.66°")
