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
  with the default solver ``"gn-reduction"`` (:func:`gn_reduction`) the levels are those
  of its last Gauss-Newton step, linearised one step (< 1e-6 relative in ½χ²) before the
  result: 2e-9 to 8e-9 of :math:`\sqrt{\Sigma_{ii}\Sigma_{kk}}` from the marginals at
  the result, the size of ``"joint"``'s own error;
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
from slam.chain_reduction import chain_solve, epoch_factors, reduce_chain
from slam.kinds.attitude.simulate import AttitudeLog
from slam.results import REFERENCE, EstimateSeries

Array = NDArray[np.float64]

#: The ways to compute the marginals (module docstring) and the default.
MARGINAL_METHODS = ("joint", "chain", "reduction")
MARGINAL_METHOD = "reduction"
#: The solvers: GTSAM's Levenberg-Marquardt (the old path), Gauss-Newton (the same stopping
#: rule; no damped trial systems on this nearly linear problem; sequential Cholesky in the
#: chain's order), or ``"gn-reduction"`` (default): Gauss-Newton whose first step is
#: GTSAM's and whose later steps are solved by the reduction (:func:`gn_reduction`).
SOLVERS = ("lm", "gauss-newton", "gn-reduction")
SOLVER = "gn-reduction"
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
#: The solvers' stopping rule: the relative and absolute decrease of ½χ².
REL_TOL, ABS_TOL = 1e-6, 1e-9


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
    # keyword arguments: pybind11 skips the other overloads by name instead of by a failed
    # conversion (Values.insert has 46; a vector is its second)
    for j in range(M):
        values.insert(X[j], rot3=inits[j])
        values.insert(B[j], zero3)
    no_drift = [0.0, 0.0, 0.0]  # a list converts faster than an array here (measured)
    for j in range(M - 1):
        pim = gtsam.PreintegratedAhrsMeasurements(params, zero3, T, gtsam.Rot3(R=dR[j]),
                                                  dR_db[j], cov[j])
        graph.add(gtsam.AHRSFactor(X[j], X[j + 1], B[j], pim))
        graph.add(gtsam.BetweenFactorVector(B[j], B[j + 1], no_drift, rw_noise))
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


def _converged(before: float, after: float, rel_tol: float, abs_tol: float) -> bool:
    """GTSAM's ``checkConvergence`` (error threshold 0): ½χ² zero, or its decrease at most
    ``abs_tol`` or at most ``rel_tol`` of ``before`` (an increase stops too)."""
    return after <= 0.0 or before - after <= abs_tol or (before - after) / before <= rel_tol


def gn_reduction(graph: Any, values: Any, params: Any, X: list[int], B: list[int],
                 rel_tol: float, abs_tol: float, max_iterations: int = 100,
                 covariances: bool = True) -> tuple[Any, Array | None]:
    r"""Gauss-Newton with GTSAM's stopping rule (:func:`_converged`): the first step by
    GTSAM's ``GaussNewtonOptimizer`` (``params``), every later one by the reduction of
    the whitened rows linearised at the current values
    (:func:`~slam.chain_reduction.chain_solve`: the same least-squares problem, solved by
    orthogonal transformations), so the levels of the last step give the
    ``[δθ_j, δb_j]`` marginals with no further linearisation.  Returns the result and
    those marginals (M, 6, 6), linearised at the values the last step was taken from
    (None if GTSAM's first step already converged, or not ``covariances``): from the star
    start the result is two steps away, and the second changes ½χ² by ~1e-7 relative."""
    import gtsam

    opt = gtsam.GaussNewtonOptimizer(graph, values, params)
    before = opt.error()
    opt.iterate()
    current, after = opt.values(), opt.error()
    covs, slots = None, _slots(X, B)
    for _ in range(max_iterations - 1):
        if _converged(before, after, rel_tol, abs_tol):
            break
        local, _, base, rhs = linear_rows(graph.linearize(current), current.dims(), slots,
                                          6, 0)
        levels, R_inv, d = reduce_chain(epoch_factors(local, rhs, base, len(X)))
        delta = chain_solve(levels, R_inv, d)
        step = gtsam.VectorValues()
        put = step.insert
        for x, b, d_theta, d_bias in zip(X, B, delta[:, :3].copy(), delta[:, 3:].copy()):
            put(x, d_theta)
            put(b, d_bias)
        covs = chain_reduction_covariances(levels, R_inv) if covariances else None
        current = current.retract(step)
        before, after = after, graph.error(current)
    return current, covs


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
    params.setRelativeErrorTol(REL_TOL)
    params.setAbsoluteErrorTol(ABS_TOL)
    if solver != "lm":  # eliminate along the chain, no fill-reducing ordering
        order = gtsam.Ordering()
        for x, b in zip(X, B):
            order.push_back(x)
            order.push_back(b)
        params.setOrdering(order)
        params.setLinearSolverType("SEQUENTIAL_CHOLESKY")
    reduced = None
    if solver == "gn-reduction":
        result, reduced = gn_reduction(graph, values, params, X, B, REL_TOL, ABS_TOL,
                                       covariances=marginals and marginal_method == "reduction")
    else:
        optimizer = (gtsam.LevenbergMarquardtOptimizer if solver == "lm"
                     else gtsam.GaussNewtonOptimizer)
        result = optimizer(graph, values, params).optimize()
    means = np.empty((M, 7))
    means[:, :4] = dcm_to_q(np.array([result.atRot3(k).matrix() for k in X]))
    biases = gtsam.utilities.extractVectors(result, "b")  # key order: B (the only vectors)
    if biases.shape != (M, 3):
        raise ValueError(f"expected {M} bias vectors, got {biases.shape}")
    means[:, 4:] = biases
    solve_s = time.perf_counter() - t0
    covs = np.full((M, 6, 6), np.nan)
    t1 = time.perf_counter()
    if marginals and reduced is not None and marginal_method == "reduction":
        covs = reduced  # the last step's levels (gn_reduction)
    elif marginals:
        covs = {"joint": joint_marginals, "chain": chain_covariances,
                "reduction": reduction_covariances}[marginal_method](graph, result, X, B)
    return EstimateSeries(REFERENCE, means, covs, M - 1, nis=np.full(M, np.nan), nis_dof=0,
                          time_s=solve_s, extra_time_s=time.perf_counter() - t1)
