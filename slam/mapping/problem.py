r"""Vehicle-map SLAM: one mean and one (square-root) covariance over the vehicle and
every landmark seen so far, run over a :class:`~slam.kinds.planar.log.PlanarLog` (or any log turned
into a :class:`SlamProblem`, e.g. a recorded one, :mod:`slam.kinds.recorded.run`).

The filter runs on sensor epochs: every ``epoch_steps`` control steps (the sensor's
scan period) and at every step with observations.  Between epochs it predicts once
through the compounded motion model with every step's control noise as an input
(:func:`~slam.kinds.planar.models.motion_model`); at an epoch it first updates with all
re-observed landmarks in one batch, then augments the state with the new ones
(inverse observation; Bailey's order).

Two modes share this one loop (:func:`run_problem`) and differ only in the three step
functions it calls:

``joint``
    sigma points over the whole joint state, as the paper does (the filter's own
    ``predict``/``update`` on the joint belief);
``local``
    sigma points only over the blocks a step touches, the rest of the joint state carried
    by exact linear relations and rank-k updates of the joint factor
    (the filter's partitioned steps, ``filt.partitioned(layout)``,
    :mod:`estimators.partitioned`; EKF and the square-root sigma-point filters).

Numerical failure (loss of positive definiteness, a non-finite estimate) or a
vehicle error beyond ``diverge_m`` ends the run and is reported as a divergence in
the result; it never raises out of :func:`run_slam` / :func:`run_problem`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from estimators import make_filter, settings_for
from estimators.linalg import Array
from estimators.loop import Divergence, run_epochs
from estimators.models import Belief, Gaussian, Innovation, Measurement, SqrtGaussian, Transition
from estimators.partitioned import BlockLayout
from slam.mapping.map_series import MapRecorder, MapSeries, vehicle_variances
from slam.results import EstimatorRun

#: The filter modes (``[filters] mode`` in a world file, ``--mode`` on the command line).
MODES: tuple[str, ...] = ("joint", "local")

#: Layout of the planar state: the pose ``[x, y, φ]``, then 2-D landmarks.


@dataclass(frozen=True)
class SlamResult(EstimatorRun):
    """What one filter produced on one log (an :class:`~slam.results.EstimatorRun`).

    Attributes
    ----------
    name : str
    steps : (E,) the epochs (control-step indices, from 0 to K).
    poses : (E, nv) vehicle means per epoch (NaN after a divergence).
    pose_cov : (E, r, r) covariance of the recorded vehicle rows per epoch (all by default).
    landmark_ids : (L,) ids of the mapped landmarks (``-1`` for a landmark created by
        nearest-neighbour association, whose true id the filter cannot know).
    landmarks : (L, 2) final landmark means; landmark_cov : (L, 2, 2).
    nis : (U,) normalised innovation squared per batch update; nis_dof : (U,).
    time_s : wall time of the filter loop.
    diverged : bool; failure : reason or ``None``; epochs_done : the last epoch recorded.
    nis_epoch : (U,) the epoch of each batch update; vehicle_var : (E, vehicle tangent)
    the vehicle's variances per epoch; map_series : the map per epoch
    (:class:`~slam.mapping.map_series.MapSeries`).  ``time_s`` leaves out the time spent
    recording these.
    """

    name: str
    steps: Array
    poses: Array
    pose_cov: Array
    landmark_ids: Array
    landmarks: Array
    landmark_cov: Array
    epochs_done: int = 0
    nis_epoch: Array | None = None
    vehicle_var: Array | None = None
    map_series: MapSeries | None = None


@dataclass(frozen=True)
class SlamProblem:
    """A log as the filter loop sees it: the vehicle first, then the landmarks.

    Attributes
    ----------
    x0, P0 : initial vehicle mean and covariance (``P0`` may be zero).
    steps : (E,) epochs (step indices, increasing, from 0).
    motion : ``motion(k0, k1, belief) -> (transition, u)`` from epoch step ``k0`` to
        ``k1``; the transition moves the vehicle coordinates of a state of any width and
        copies the rest (``belief`` is the current one, for models linearised at it; local
        mode passes the vehicle's marginal, ``layout.vehicle(belief)``).
    observations : step -> slice of ``obs`` / ``obs_id`` taken at that step.
    obs : (M, dz) observations; obs_id : (M,) their landmark ids.
    observe : ``observe(slots, index) -> Measurement`` of the landmarks in state slots
        ``slots`` by the observations ``obs[index]``; the measurement is of a state
        ``[vehicle; landmarks...]`` (joint mode: the whole state; local mode: the block
        ``[vehicle; landmarks in slots]``, passed with ``slots = 0..k-1``).
    augment : ``augment(n_landmarks, z_new, index) -> Transition`` into a state with the
        new landmarks appended (local mode passes ``n_landmarks = 0``).
    layout : the state's block layout (ambient and tangent sizes of the vehicle and of a
        landmark) and spaces.
    truth : (K + 1, >= position_dims) true positions by step, or ``None`` (no divergence
        distance); position_dims : how many leading coordinates are the position.
    nearest : ``nearest(belief, z, n_landmarks, gates) -> slot | -1 | None`` for
        nearest-neighbour association, or ``None`` (ids only).
    record_rows : the vehicle's tangent rows whose covariance is recorded per epoch
        (default: all of them).
    true_landmarks : (N, landmark ambient) true landmark positions by id, or ``None``;
        only for scoring the map per epoch (:class:`~slam.mapping.map_series.MapSeries`).
    group : local mode with a group error (``<filter>-inv`` in local mode): ``n -> space``
        of the group (e.g. :class:`~estimators.slam_group.SlamGroup`) whose error the
        filter keeps (a space with ``retract_world`` and ``transport``); the belief stays in the
        world chart of ``layout`` and every correction is moved on the group with its
        covariance transported (:mod:`estimators.group_transport`).  ``None``: no transport.
    batchable : the models broadcast over a leading batch axis (points (B, m, n), inputs
        (B, ...)), so runs of the same layout may share a batch (:mod:`slam.mapping.batch`):
        with ``motion``'s model independent of the belief (called with ``None``), or with
        the two parts below.
    motion_input, motion_model : ``motion`` in two parts for a batch whose model is built
        along the belief (the drone's): ``motion_input(k0, k1)`` the run's input, and
        ``motion_model(k0, k1, belief, u)`` the transition of a batch of beliefs with the
        stacked inputs (``None``: ``motion`` serves).
    """

    x0: Array
    P0: Array
    steps: Array
    motion: Callable[[int, int, Belief], tuple[Transition, Any]]
    observations: dict[int, slice]
    obs: Array
    obs_id: Array
    observe: Callable[[Array, Array], Measurement]
    augment: Callable[[int, Array, Array], Transition]
    layout: BlockLayout
    truth: Array | None = None
    position_dims: int = 2
    nearest: Callable[..., int | None] | None = None
    record_rows: Array | None = None
    true_landmarks: Array | None = None
    group: Callable[[int], Any] | None = None
    batchable: bool = False
    motion_input: Callable[[int, int], Any] | None = None
    motion_model: Callable[[int, int, Belief, Any], Transition] | None = None

    def landmark_rows(self, slot: int) -> Array:
        """Tangent rows of landmark ``slot``."""
        return self.layout.rows([slot])[self.layout.vehicle_dim:]


class _JointSteps:
    """``joint`` mode: the filter's own predict/update on the whole joint belief."""

    def __init__(self, filt, problem: SlamProblem):
        self.filt, self.problem = filt, problem

    def predict(self, b: Belief, model: Transition, u: Any) -> Belief:
        return self.filt.predict(b, model, u)

    def update(self, b: Belief, slots: Array, index: Array, z: Array
               ) -> tuple[Belief, Innovation]:
        return self.filt.update(b, self.problem.observe(slots, index), z)

    def augment(self, b: Belief, n_before: int, z_new: Array, index: Array) -> Belief:
        return self.filt.predict(b, self.problem.augment(n_before, z_new, index), z_new)


class _LocalSteps:
    """``local`` mode: the filter's partitioned steps (:mod:`estimators.partitioned`)."""

    def __init__(self, filt, problem: SlamProblem):
        self.steps, self.problem = filt.partitioned(problem.layout), problem

    def predict(self, b: Belief, model: Transition, u: Any) -> Belief:
        return self.steps.predict(b, model, u)

    def update(self, b: Belief, slots: Array, index: Array, z: Array
               ) -> tuple[Belief, Innovation]:
        model = self.problem.observe(np.arange(len(slots)), index)
        post, innovation = self.steps.update(b, slots, model, z)
        group = self.problem.group
        if group is None:
            return post, innovation
        return _on_group(group(self.problem.layout.n_landmarks(b.dim)), b, post), innovation

    def augment(self, b: Belief, n_before: int, z_new: Array, index: Array) -> Belief:
        return self.steps.augment(b, self.problem.augment(0, z_new, index), z_new)


def _on_group(space: Any, prior: Belief, post: Belief) -> Belief:
    """``post`` (world chart) with its correction made on the group ``space`` and its
    covariance transported there (:mod:`estimators.group_transport`): the invariant
    filter's update, to first order (exactly, for the EKF)."""
    x = prior.mean
    mean = space.retract_world(x, prior.space.local(x, post.mean))
    if isinstance(post, SqrtGaussian):
        return SqrtGaussian(mean, space.transport(x, mean, sqrt=post.sqrt), post.space)
    return Gaussian(mean, space.transport(x, mean, cov=post.cov), post.space)


def variant_problem(make: Callable[[str | None], SlamProblem], filter_name: str,
                    variant: str | None, mode: str, local_names: tuple[str, ...],
                    group: Callable[[int], Any] | None) -> SlamProblem:
    """The problem ``make(variant)`` of ``filter_name`` (``<base>-<variant>``) in ``mode``.
    In local mode a group-error variant runs the standard problem, ``make(None)``, with
    ``group`` set (its covariance kept in the world chart and transported, see
    :class:`SlamProblem`); a name not in ``local_names`` raises ``ValueError``."""
    if mode != "local" or variant is None:
        return make(variant)
    if filter_name not in local_names or group is None:
        raise ValueError(f"{filter_name} has no local mode (local: {', '.join(local_names)})")
    return replace(make(None), group=group)


def run_problem(problem: SlamProblem, filter_name: str, *, mode: str = "joint",
                association: str = "known", gates: tuple[float, float] = (4.0, 25.0),
                diverge_m: float = 50.0, filter_params: dict | None = None) -> SlamResult:
    """Run one filter over a :class:`SlamProblem` through the one filter loop
    (:func:`estimators.loop.run_epochs`); see :func:`run_slam`."""
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}; choose from {', '.join(MODES)}")
    if association not in ("known", "nn"):
        raise ValueError(f"unknown association {association!r}; choose known or nn")
    if association == "nn" and problem.nearest is None:
        raise ValueError("this log has no nearest-neighbour association; use known ids")
    # a variant ``<base>-<variant>`` is the base filter; the problem carries the variant
    base = filter_name.partition("-")[0]
    filt = make_filter(base, **settings_for(base, filter_params or {}))
    ops = (_LocalSteps if mode == "local" else _JointSteps)(filt, problem)
    lay = problem.layout
    nv, nvt = lay.vehicle_ambient, lay.vehicle_dim
    steps = problem.steps
    space0 = problem.layout.space_of(0)
    P0 = _chart_prior(space0, problem.x0, np.asarray(problem.P0, dtype=float))
    if np.any(P0) and np.any(P0 != np.diag(np.diag(P0))):
        b: Belief = filt.init(problem.x0, space0, cov=P0)
    else:  # zero or diagonal: the factor directly
        b = filt.init(problem.x0, space0, sqrt=np.diag(np.sqrt(np.diag(P0))))
    E = len(steps)
    poses = np.full((E, nv), np.nan)
    rows = np.arange(nvt) if problem.record_rows is None else np.asarray(problem.record_rows)
    covs = np.full((E, len(rows), len(rows)), np.nan)
    assoc = _Association(problem, ops, association, gates)
    maps = MapRecorder(lay, E, problem.true_landmarks)
    var = np.full((E, nvt), np.nan)

    def record(e: int, b: Belief) -> None:
        b = world_belief(b)
        poses[e], covs[e] = b.mean[:nv], b.cov_block(rows)
        var[e] = vehicle_variances(b, nvt)
        maps.record(e, b, assoc.slot_ids)

    def check(e: int, b: Belief) -> None:
        truth, k1, d = problem.truth, int(steps[e]), problem.position_dims
        if truth is not None:
            err = float(np.linalg.norm(b.mean[:d] - truth[k1, :d]))
            if err > diverge_m:
                raise Divergence(f"vehicle error above {diverge_m} m at step {k1} "
                                 f"(position error {err:.3g} m)")

    def transition(e: int, b: Belief) -> tuple[Transition, Any]:
        # local mode predicts the vehicle alone: its model is built for the vehicle marginal
        at = lay.vehicle(b) if mode == "local" else b
        return problem.motion(int(steps[e - 1]), int(steps[e]), at)

    out = run_epochs(filt, b, E, steps=ops, record=record, check=check, transition=transition,
                     correct=lambda e, b: assoc.correct(int(steps[e]), b))
    b = world_belief(out.belief)
    # the last good belief: an epoch that failed may have named slots it never added
    n_lm, nla, nl = lay.n_landmarks(b.dim), lay.landmark_ambient, lay.landmark_dim
    lm = b.mean[nv:nv + nla * n_lm].reshape(n_lm, nla)
    lm_cov = np.array([b.cov_block(problem.landmark_rows(s)) for s in range(n_lm)]
                      ).reshape(n_lm, nl, nl)
    ids = np.array(assoc.slot_ids[:n_lm], dtype=int)
    return SlamResult(filter_name, steps, poses, covs, ids, lm, lm_cov, out.epochs_done,
                      out.nis_epoch, var, maps.series(), nis=out.nis, nis_dof=out.nis_dof,
                      time_s=max(out.time_s - maps.seconds, 0.0), diverged=out.diverged,
                      failure=out.failure)


def world_belief(b: Belief) -> Belief:
    """``b`` with its covariance in the world chart when its space is a group with error
    coordinates of its own (a space with ``to_world``, e.g.
    :class:`~estimators.slam_group.SlamGroup`: first order, :math:`P_w = M P M^\top`);
    otherwise ``b`` itself.  A batch of beliefs gives the batch of world-chart beliefs."""
    to_world = getattr(b.space, "to_world", None)
    if to_world is None:
        return b
    if isinstance(b, SqrtGaussian):
        return SqrtGaussian(b.mean, to_world(b.mean, b.sqrt), b.space)
    MP = to_world(b.mean, b.cov)
    return Gaussian(b.mean, to_world(b.mean, np.swapaxes(MP, -1, -2)), b.space)


def _chart_prior(space: Any, x0: Array, P0: Array) -> Array:
    """The prior covariance (world chart) in the space's own error coordinates."""
    from_world = getattr(space, "from_world", None)
    if from_world is None or not np.any(P0):
        return P0
    return from_world(x0, from_world(x0, P0).T)


class _Association:
    """The measurement side of a SLAM epoch: association (known ids or gated nearest
    neighbour), the batch update with the re-observed landmarks, then augmentation with
    the new ones (Bailey's order)."""

    def __init__(self, problem: SlamProblem, ops: Any, association: str,
                 gates: tuple[float, float]):
        self.problem, self.ops, self.association, self.gates = problem, ops, association, gates
        self.slot_ids: list[int] = []
        self.slot_of: dict[int, int] = {}

    def _slot(self, b: Belief, z: Array, lid: int, n_before: int) -> int | None:
        if self.association == "known":
            return self.slot_of.get(int(lid), -1)
        return self.problem.nearest(b, z, n_before, self.gates)

    def correct(self, step: int, b: Belief) -> tuple[Belief, list[Innovation]]:
        problem = self.problem
        sl = problem.observations.get(step)
        if sl is None:
            return b, []
        matched_slots, matched_z, matched_i, new_z, new_i = [], [], [], [], []
        late: list[tuple[int, Array, int]] = []  # landmarks first seen in this epoch, again
        n_before = len(self.slot_ids)
        Z, ids = problem.obs[sl], problem.obs_id[sl]
        for i, (z, lid) in enumerate(zip(Z, ids), start=sl.start or 0):
            slot = self._slot(b, z, lid, n_before)
            if slot is None:
                continue
            if slot >= n_before:
                late.append((slot, z, i))
            elif slot >= 0:
                matched_slots.append(slot)
                matched_z.append(z)
                matched_i.append(i)
            else:
                new_z.append(z)
                new_i.append(i)
                self.slot_of[int(lid)] = n_before + len(new_z) - 1
                self.slot_ids.append(int(lid) if self.association == "known" else -1)
        inns = []
        if matched_slots:
            b, inn = self.ops.update(b, np.array(matched_slots), np.array(matched_i),
                                     np.concatenate(matched_z))
            inns.append(inn)
        if new_z:
            b = self.ops.augment(b, n_before, np.concatenate(new_z), np.array(new_i))
        if late:  # their second sightings update the state they were just added to
            slots, zs, index = zip(*late)
            b, inn = self.ops.update(b, np.array(slots), np.array(index), np.concatenate(zs))
            inns.append(inn)
        return b, inns


