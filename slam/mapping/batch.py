"""Vehicle-map SLAM for a batch of runs at once: :func:`run_problems` is
:func:`~slam.mapping.problem.run_problem` for many logs of the same world, with the runs as
an array axis through the filter (:mod:`estimators.batch`).

Which runs share a batch
    Runs are stacked only where their filters see the same *layout* at every epoch: the
    same epochs, the same observed landmark ids in the same order at each of them (so the
    same state slots, updates and augmentations), in joint mode, with known association,
    for a filter whose models broadcast over a batch (:attr:`SlamProblem.batchable`, the
    standard-error problems).  The runs are grouped by that layout before anything runs;
    a group of one, nearest-neighbour association (whose slots depend on each run's own
    estimates), local mode and the variants run per run, through ``run_problem``.  So the
    regrouping can never give a wrong answer: a run is batched only with runs whose every
    step is the same computation on other numbers.

Every result is what ``run_problem`` returns for that run (``tests/slam/test_batch.py``):
a failing run ends alone with the per-run reason (:func:`estimators.batch.run_batch`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from estimators import make_filter, settings_for
from estimators.batch import BatchRuns, advance, member, stack, take
from estimators.linalg import Array
from estimators.loop import Divergence
from estimators.models import Belief, Innovation, SqrtGaussian
from slam.mapping.map_series import BatchMapRecorder
from slam.mapping.problem import SlamProblem, SlamResult, _chart_prior, _JointSteps, run_problem

__all__ = ["run_problems", "step_groups"]


def step_groups(problems: Sequence[SlamProblem], batched: bool) -> list[list[int]]:
    """Indices of the problems grouped by their epochs (runs with the same epochs can share
    a batch; within a group the observation layouts may still differ: regrouped epoch by
    epoch); every problem alone when ``batched`` is false."""
    if not batched:
        return [[i] for i in range(len(problems))]
    out: dict[bytes, list[int]] = {}
    for i, p in enumerate(problems):
        out.setdefault(np.asarray(p.steps, dtype=np.int64).tobytes(), []).append(i)
    return list(out.values())


def run_problems(problems: Sequence[SlamProblem], filter_name: str, *, mode: str = "joint",
                 association: str = "known", gates: tuple[float, float] = (4.0, 25.0),
                 diverge_m: float = 50.0, filter_params: dict | None = None,
                 batched: bool = True) -> list[SlamResult]:
    """:func:`~slam.mapping.problem.run_problem` of each problem, runs with the same epochs
    as one batch regrouped by layout epoch by epoch (module docstring); ``batched=False``
    runs each alone."""
    kw = dict(mode=mode, association=association, gates=gates, diverge_m=diverge_m,
              filter_params=filter_params)
    can = (batched and mode == "joint" and association == "known"
           and all(p.batchable for p in problems))
    out: list[SlamResult | None] = [None] * len(problems)
    for group in step_groups(problems, can):
        if len(group) == 1:
            out[group[0]] = run_problem(problems[group[0]], filter_name, **kw)  # type: ignore
            continue
        results = _run_group([problems[i] for i in group], filter_name, diverge_m,
                             filter_params)
        for i, r in zip(group, results):
            out[i] = r
    return out  # type: ignore[return-value]


def _structure(problem: SlamProblem, step: int, slot_ids: list[int]
               ) -> tuple[list, list, list, list[int]]:
    """``(matched (slot, index), new indices, late (slot, index), slot ids after)`` of
    ``problem``'s observations at ``step`` for a state holding ``slot_ids`` (known ids,
    Bailey's order: the per-run association's)."""
    sl = problem.observations.get(step)
    ids = list(slot_ids)
    if sl is None:
        return [], [], [], ids
    slot_of = {lid: s for s, lid in enumerate(ids)}
    n_before = len(ids)
    matched, new, late = [], [], []
    for i, lid in enumerate(problem.obs_id[sl], start=sl.start or 0):
        slot = slot_of.get(int(lid), -1)
        if slot >= n_before:
            late.append((slot, i))
        elif slot >= 0:
            matched.append((slot, i))
        else:
            new.append(i)
            slot_of[int(lid)] = len(ids)
            ids.append(int(lid))
    return matched, new, late, ids


def _initial(filt: Any, problems: Sequence[SlamProblem]) -> Belief:
    beliefs = []
    for p in problems:
        space0 = p.layout.space_of(0)
        P0 = _chart_prior(space0, p.x0, np.asarray(p.P0, dtype=float))
        if np.any(P0) and np.any(P0 != np.diag(np.diag(P0))):
            beliefs.append(filt.init(p.x0, space0, cov=P0))
        else:
            beliefs.append(filt.init(p.x0, space0, sqrt=np.diag(np.sqrt(np.diag(P0)))))
    return stack(beliefs)


def _run_group(problems: Sequence[SlamProblem], filter_name: str, diverge_m: float,
               filter_params: dict | None) -> list[SlamResult]:
    """The runs of one step group through the filter as cohorts: the runs whose states hold
    the same landmark slots share a batch; each cohort is split by the runs' observation
    layouts at every epoch, and the parts regrouped by their new slots after it."""
    p0 = problems[0]
    base = filter_name.partition("-")[0]
    filt = make_filter(base, **settings_for(base, filter_params or {}))
    ops = _JointSteps(filt, p0)
    lay, steps = p0.layout, p0.steps
    nv, nvt = lay.vehicle_ambient, lay.vehicle_dim
    B, E = len(problems), len(steps)
    rows = np.arange(nvt) if p0.record_rows is None else np.asarray(p0.record_rows)
    poses = np.full((B, E, nv), np.nan)
    covs = np.full((B, E, len(rows), len(rows)), np.nan)
    var = np.full((B, E, nvt), np.nan)
    obs = np.stack([np.asarray(p.obs, dtype=float) for p in problems])  # (B, M, dz)
    truth = (None if p0.truth is None else
             np.stack([np.asarray(p.truth, dtype=float) for p in problems]))
    maps = BatchMapRecorder(lay, B, E, p0.true_landmarks)
    runs = BatchRuns(B)
    final_ids: list[list[int]] = [[] for _ in range(B)]

    def transition(e: int, b: Belief, live: Array):
        k0, k1 = int(steps[e - 1]), int(steps[e])
        model, _ = p0.motion(k0, k1, None)  # type: ignore[arg-type]
        u = np.stack([np.asarray(problems[r].motion(k0, k1, None)[1])  # type: ignore[arg-type]
                      for r in live])
        return model, u

    def check(e: int, b: Belief, live: Array) -> None:
        if truth is None:
            return
        k1, d = int(steps[e]), p0.position_dims
        err = np.linalg.norm(b.mean[:, :d] - truth[live, k1, :d], axis=1)
        for j in np.flatnonzero(err > diverge_m):
            if len(live) == 1:
                raise Divergence(f"vehicle error above {diverge_m} m at step {k1} "
                                 f"(position error {err[j]:.3g} m)")
            raise Divergence("a member left its bounds")  # found member by member

    def hooks(structure: tuple[list, list, list, list[int]], n_before: int):
        matched, new, late, ids = structure

        def correct(e: int, b: Belief, live: Array) -> tuple[Belief, list[Innovation]]:
            z_of = obs[live]
            inns = []
            if matched:
                slots, index = (np.array(v) for v in zip(*matched))
                b, inn = ops.update(b, slots, index, z_of[:, index].reshape(len(live), -1))
                inns.append(inn)
            if new:
                index = np.array(new)
                z_new = z_of[:, index].reshape(len(live), -1)
                b = filt.predict(b, p0.augment(n_before, z_new[0], index), z_new)
            if late:
                slots, index = (np.array(v) for v in zip(*late))
                b, inn = ops.update(b, slots, index, z_of[:, index].reshape(len(live), -1))
                inns.append(inn)
            return b, inns

        def record(e: int, b: Belief, live: Array) -> None:
            poses[live, e] = b.mean[:, :nv]
            covs[live, e] = b.cov_block(rows)
            var[live, e] = (np.sum(b.sqrt[:, :nvt] ** 2, axis=2)
                            if isinstance(b, SqrtGaussian)
                            else np.diagonal(b.cov, axis1=1, axis2=2)[:, :nvt])
            maps.record(e, b, live, ids)

        return (transition, correct, record, check)

    cohorts: list[tuple[Belief, Array, list[int]]] = [(_initial(filt, problems), np.arange(B),
                                                       [])]
    with np.errstate(divide="raise", over="raise", invalid="raise", under="ignore"):
        for e in range(E):
            k = int(steps[e])
            parts: dict[tuple[int, ...], list[tuple[Belief, Array]]] = {}
            for b, live, ids in cohorts:
                by_layout: dict[tuple[int, ...], list[int]] = {}
                for j, r in enumerate(live):
                    sl = problems[r].observations.get(k)
                    key = () if sl is None else tuple(int(i) for i in problems[r].obs_id[sl])
                    by_layout.setdefault(key, []).append(j)
                for js in by_layout.values():
                    sub, lv = (b, live) if len(js) == len(live) else (take(b, js), live[js])
                    structure = _structure(problems[int(lv[0])], k, ids)
                    for r in lv:
                        final_ids[r] = ids
                    h = hooks(structure, len(ids))

                    def step(e: int, bb: Belief, lv: Array, h=h) -> Belief:
                        return runs.epoch(ops, h, e, bb, lv)

                    sub, lv = advance(runs, step, e, sub, lv)
                    if lv.size:
                        parts.setdefault(tuple(structure[3]), []).append((sub, lv))
            cohorts = [(p[0][0] if len(p) == 1 else stack([x[0] for x in p]),
                        np.concatenate([x[1] for x in p]), list(key))
                       for key, p in parts.items()]
    finals: dict[int, Belief] = {}
    for b, live, ids in cohorts:
        for j, r in enumerate(live):
            finals[int(r)] = member(b, j)
            final_ids[r] = ids
    out = []
    for r, res in enumerate(runs.results(finals)):
        b = res.belief
        n_lm, nla, nl = lay.n_landmarks(b.dim), lay.landmark_ambient, lay.landmark_dim
        lm = b.mean[nv:nv + nla * n_lm].reshape(n_lm, nla)
        lm_cov = np.array([b.cov_block(p0.landmark_rows(s)) for s in range(n_lm)]
                          ).reshape(n_lm, nl, nl)
        ids = np.array(final_ids[r][:n_lm], dtype=int)
        out.append(SlamResult(filter_name, steps, poses[r], covs[r], ids, lm, lm_cov,
                              res.epochs_done, res.nis_epoch, var[r], maps.series(r),
                              nis=res.nis, nis_dof=res.nis_dof,
                              time_s=max(res.time_s - maps.seconds / B, 0.0),
                              diverged=res.diverged, failure=res.failure))
    return out
