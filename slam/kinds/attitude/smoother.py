r"""The star-sensor GTSAM smoother: the batch-optimal yardstick of the attitude filters.

:func:`smooth_attitude` is GTSAM on the same log: ``Rot3`` states and ``Vector3`` bias
states at the star epochs; the interval's gyro samples preintegrated by
``PreintegratedAhrsMeasurements`` into ``AHRSFactor(R_j, R_{j+1}, B_j)`` (the factor takes
one bias key: the bias is held at ``B_j`` over the interval, exactly as in the filters);
``BetweenFactorVector(B_j, B_{j+1})`` with :math:`\sigma_b\sqrt T` for the random walk;
``PriorFactorRot3`` per star quaternion (or ``AttitudeFactorRot3`` per star vector);
priors on ``R_0``, ``B_0`` equal to the filters' initial belief.  Its marginals are
body-frame (right perturbation), the same chart as the filters', so they go into the
same NEES without conversion.

Marginals, three ways (``marginal_method``):

- ``"joint"``: GTSAM's ``Marginals`` and one ``jointMarginalCovariance([R_j, B_j])`` per
  epoch (each a walk of the Bayes tree);
- ``"reduction"`` (default): once, by square-root cyclic reduction
  (:mod:`slam.chain_reduction`; batched QR per level, equal to ``"chain"`` to ~1e-11);
- ``"chain"``: once, by the square-root sweep of :mod:`slam.chain_marginals`
  over the whitened Jacobian (every factor touches one epoch or two consecutive ones; the
  epoch's columns ``[δθ_j, δb_j]``).  On the 120 s star-sensor world it agrees with an
  extended-precision (``longdouble``) inverse of :math:`J^\top J` to 6e-12 of
  :math:`\sqrt{\Sigma_{ii}\Sigma_{kk}}`, where ``"joint"`` is off by 7e-9 (the Bayes
  tree's Cholesky at an information span of ~1e17).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nav.gyro import dead_reckoning
from nav.preintegration import preintegrate_rotation
from nav.quaternion import dcm_to_q, qto_dcm
from slam.chain_marginals import chain_marginals, jacobian_rows, linear_rows
from slam.chain_reduction import chain_covariances as chain_reduction_covariances
from slam.chain_reduction import epoch_factors, reduce_chain
from slam.kinds.attitude.simulate import AttitudeLog
from slam.results import REFERENCE, EstimateSeries

Array = NDArray[np.float64]

#: The ways to compute the marginals (module docstring) and the default.
MARGINAL_METHODS = ("joint", "chain", "reduction")
MARGINAL_METHOD = "reduction"
#: The solvers: GTSAM's Levenberg-Marquardt (the old path) or Gauss-Newton (default; the
#: same stopping rule; no damped trial systems on this nearly linear problem; sequential
#: Cholesky in the chain's order).
SOLVERS = ("lm", "gauss-newton")
SOLVER = "gauss-newton"
#: How the gyro intervals are preintegrated: ``"samples"`` by GTSAM's
#: ``integrateMeasurement`` per sample (the old path), ``"batched"`` (default) by
#: :func:`nav.preintegration.preintegrate_rotation` over all intervals at once (the same
#: recursion, equal to round-off) into ``PreintegratedAhrsMeasurements``' array constructor.
PREINTEGRATIONS = ("samples", "batched")
PREINTEGRATION = "batched"
#: The start in vector mode: ``"dead-reckoning"`` from ``x0`` (the old path; degrees off
#: after minutes) or ``"wahba"`` (default): each epoch's attitude from its own star vectors
#: (:func:`wahba`, within the star noise), so Gauss-Newton needs two steps, not four.
VECTOR_STARTS = ("dead-reckoning", "wahba")
VECTOR_START = "wahba"


def wahba(refs: Array, vectors: Array) -> Array:
    r"""(M, 3, 3) the least-squares attitudes :math:`C_j = \arg\min_C \sum_i
    \|r_i - C b_{ji}\|^2` (Wahba's problem; ``refs`` (k, 3) nav frame, ``vectors``
    (M, k, 3) body frame, k >= 2 not parallel): with :math:`\sum_i r_i b_{ji}^\top =
    U S V^\top`, :math:`C_j = U\,\mathrm{diag}(1, 1, \det U \det V)\,V^\top`."""
    U, _, Vt = np.linalg.svd(np.einsum("ia,mib->mab", refs, vectors))
    d = np.ones((len(U), 3))
    d[:, 2] = np.linalg.det(U) * np.linalg.det(Vt)
    return (U * d[:, None, :]) @ Vt


def attitude_graph(log: AttitudeLog, x0: Array, P0: Array, arw: float, bias_rw: float,
                   star_sigma: float, preintegration: str = PREINTEGRATION,
                   vector_start: str = VECTOR_START) -> tuple[Any, Any, list[int], list[int]]:
    """The factor graph of the log (module docstring) with its initial values (the star
    quaternions; in vector mode as ``vector_start`` of :data:`VECTOR_STARTS`) and the keys
    ``X``, ``B``; ``preintegration`` as in :data:`PREINTEGRATIONS`."""
    import gtsam

    for name, got, allowed in (("preintegration", preintegration, PREINTEGRATIONS),
                               ("vector_start", vector_start, VECTOR_STARTS)):
        if got not in allowed:
            raise ValueError(f"{name} {got!r}: one of {', '.join(allowed)}")

    M, n, dt = log.n_star, log.samples_per_star, log.dt
    X = [gtsam.symbol("x", j) for j in range(M)]
    B = [gtsam.symbol("b", j) for j in range(M)]
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()

    def rot(q: Array) -> Any:
        return gtsam.Rot3.Quaternion(float(q[0]), float(q[1]), float(q[2]), float(q[3]))

    params = gtsam.PreintegratedRotationParams()
    params.setGyroscopeCovariance(arw**2 * np.eye(3))
    graph.add(gtsam.PriorFactorRot3(X[0], rot(x0[:4]),
                                    gtsam.noiseModel.Isotropic.Sigma(3, math.sqrt(P0[0, 0]))))
    graph.add(gtsam.PriorFactorVector(B[0], np.zeros(3),
                                      gtsam.noiseModel.Isotropic.Sigma(3, math.sqrt(P0[3, 3]))))
    rw_noise = gtsam.noiseModel.Isotropic.Sigma(3, max(bias_rw * math.sqrt(n * dt), 1e-15))
    if log.star_q is not None:
        star_noise = gtsam.noiseModel.Isotropic.Sigma(3, star_sigma)
        stars = [gtsam.Rot3.Quaternion(*q) for q in np.asarray(log.star_q).tolist()]
        for x, r in zip(X, stars):
            graph.add(gtsam.PriorFactorRot3(x, r, star_noise))
        guesses = log.star_q
    else:
        vec_noise = gtsam.noiseModel.Isotropic.Sigma(2, star_sigma)
        refs = [gtsam.Unit3(r) for r in log.star_refs]
        for j in range(M):
            for r, b in zip(refs, log.star_vectors[j]):
                graph.add(gtsam.AttitudeFactorRot3(X[j], r, vec_noise, gtsam.Unit3(b)))
        guesses = None
        if vector_start == "wahba":
            guesses = dcm_to_q(wahba(np.asarray(log.star_refs), np.asarray(log.star_vectors)))
    zero3 = np.zeros(3)
    if preintegration == "samples":
        if guesses is None:
            guesses = dead_reckoning(x0[:4], (log.gyro_block(j) for j in range(M - 1)), dt)
        for j in range(M):
            values.insert(X[j], rot(guesses[j]))
            values.insert(B[j], zero3)
            if j + 1 < M:
                pim = gtsam.PreintegratedAhrsMeasurements(params, zero3)
                for w in log.gyro_block(j):
                    pim.integrateMeasurement(w, dt)
                graph.add(gtsam.AHRSFactor(X[j], X[j + 1], B[j], pim))
                graph.add(gtsam.BetweenFactorVector(B[j], B[j + 1], zero3, rw_noise))
        return graph, values, X, B
    T, dR, dR_db, cov = preintegrate_rotation(
        np.reshape(log.gyro, (M - 1, n, 3)), dt, arw**2)
    if guesses is None:  # dead reckoning: R_{j+1} = R_j ΔR_j
        start = [qto_dcm(x0[:4])]
        for d in dR:
            start.append(start[-1] @ d)
        guesses = dcm_to_q(np.array(start))
    inits = (stars if log.star_q is not None
             else [gtsam.Rot3.Quaternion(*q) for q in np.asarray(guesses).tolist()])
    for j in range(M):
        values.insert(X[j], inits[j])
        values.insert(B[j], zero3)
    for j in range(M - 1):
        pim = gtsam.PreintegratedAhrsMeasurements(params, zero3, T, gtsam.Rot3(dR[j]),
                                                  dR_db[j], cov[j])
        graph.add(gtsam.AHRSFactor(X[j], X[j + 1], B[j], pim))
        graph.add(gtsam.BetweenFactorVector(B[j], B[j + 1], zero3, rw_noise))
    return graph, values, X, B


def joint_marginals(graph: Any, result: Any, X: list[int], B: list[int]) -> Array:
    """(M, 6, 6) ``[δθ_j, δb_j]`` marginals by GTSAM's ``jointMarginalCovariance``."""
    import gtsam

    covs = np.empty((len(X), 6, 6))
    marg = gtsam.Marginals(graph, result)
    for j, (x, b) in enumerate(zip(X, B)):
        jm = marg.jointMarginalCovariance([x, b])
        covs[j, :3, :3] = jm.at(x, x)
        covs[j, :3, 3:] = jm.at(x, b)
        covs[j, 3:, :3] = jm.at(b, x)
        covs[j, 3:, 3:] = jm.at(b, b)
    return covs


def _slots(X: list[int], B: list[int]) -> dict[int, tuple[int, int]]:
    """Each key's epoch and offset in the epoch's ``[δθ_j, δb_j]`` columns."""
    return {**{x: (j, 0) for j, x in enumerate(X)}, **{b: (j, 3) for j, b in enumerate(B)}}


def chain_covariances(graph: Any, result: Any, X: list[int], B: list[int]) -> Array:
    """(M, 6, 6) ``[δθ_j, δb_j]`` marginals by the square-root chain
    (:mod:`slam.chain_marginals`; no global variables)."""
    local, glob, base = jacobian_rows(graph, result, _slots(X, B), 6, 0)
    return chain_marginals(local, glob, base, len(X))[0]


def reduction_covariances(graph: Any, result: Any, X: list[int], B: list[int]) -> Array:
    """(M, 6, 6) ``[δθ_j, δb_j]`` marginals by square-root cyclic reduction
    (:mod:`slam.chain_reduction`)."""
    local, _, base, rhs = linear_rows(graph.linearize(result), result.dims(), _slots(X, B),
                                      6, 0)
    levels, R_inv, _ = reduce_chain(epoch_factors(local, rhs, base, len(X)))
    return chain_reduction_covariances(levels, R_inv)


def smooth_attitude(log: AttitudeLog, x0: Array, P0: Array, arw: float, bias_rw: float,
                    star_sigma: float, marginals: bool = True,
                    marginal_method: str = MARGINAL_METHOD, solver: str = SOLVER,
                    preintegration: str = PREINTEGRATION,
                    vector_start: str = VECTOR_START) -> EstimateSeries:
    """GTSAM batch smoother on the same log (module docstring); ``marginal_method`` one of
    :data:`MARGINAL_METHODS`, ``solver`` of :data:`SOLVERS`, ``preintegration`` of
    :data:`PREINTEGRATIONS`, ``vector_start`` of :data:`VECTOR_STARTS`.  The old default
    path is ``preintegration="samples", solver="lm", marginal_method="joint",
    vector_start="dead-reckoning"``.

    ``time_s`` covers building the graph (preintegration included) and the solve;
    ``extra_time_s`` the marginal covariances.
    """
    import gtsam

    for name, got, allowed in (("marginal_method", marginal_method, MARGINAL_METHODS),
                               ("solver", solver, SOLVERS)):
        if got not in allowed:
            raise ValueError(f"{name} {got!r}: one of {', '.join(allowed)}")
    t0 = time.perf_counter()
    M = log.n_star
    graph, values, X, B = attitude_graph(log, x0, P0, arw, bias_rw, star_sigma,
                                         preintegration, vector_start)
    # The problem is nearly linear: from the star-measurement (or dead-reckoned) start LM
    # takes two steps; the second changes ½χ² by ~1e-7 relative, and tighter tolerances
    # only add rejected LM trials (Gauss-Newton confirms the optimum to 1e-12).
    params = gtsam.LevenbergMarquardtParams() if solver == "lm" else gtsam.GaussNewtonParams()
    params.setRelativeErrorTol(1e-6)
    params.setAbsoluteErrorTol(1e-9)
    if solver == "gauss-newton":  # eliminate along the chain, no fill-reducing ordering
        order = gtsam.Ordering()
        for x, b in zip(X, B):
            order.push_back(x)
            order.push_back(b)
        params.setOrdering(order)
        params.setLinearSolverType("SEQUENTIAL_CHOLESKY")
    optimizer = (gtsam.LevenbergMarquardtOptimizer if solver == "lm"
                 else gtsam.GaussNewtonOptimizer)
    result = optimizer(graph, values, params).optimize()
    means = np.empty((M, 7))
    means[:, :4] = dcm_to_q(np.array([result.atRot3(k).matrix() for k in X]))
    means[:, 4:] = np.array([result.atVector(k) for k in B])
    solve_s = time.perf_counter() - t0
    covs = np.full((M, 6, 6), np.nan)
    t1 = time.perf_counter()
    if marginals:
        covs = {"joint": joint_marginals, "chain": chain_covariances,
                "reduction": reduction_covariances}[marginal_method](graph, result, X, B)
    return EstimateSeries(REFERENCE, means, covs, M - 1, nis=np.full(M, np.nan), nis_dof=0,
                          time_s=solve_s, extra_time_s=time.perf_counter() - t1)
