"""Vehicle-map SLAM for many runs at once: :func:`run_problems` is
:func:`~slam.mapping.problem.run_problem` for many logs of the same world, with the runs as
an array axis through the filter (:mod:`estimators.batch`).

Cohorts and regrouping
    The runs whose states hold the same landmark slots (the same ids in the same order)
    form a *cohort* and share one batch.  At every epoch each cohort is split by what its
    members do there - the same epoch steps and the same observed landmark ids (hence the
    same updates and augmentations) - each part runs the epoch as one batch, and the parts
    are regrouped into cohorts by the slots they then hold.  Runs whose truths differ (an
    uncertain start: landmarks come into view at other epochs, runs end at other steps)
    thus split where they differ and merge again where they agree: a run is batched only
    with runs doing the same computation on other numbers, so no regrouping can change a
    result.  Joint mode with known association and batchable models
    (:attr:`SlamProblem.batchable`: the standard-error problems and the planar group-error
    ones, ``-inv`` / ``-linv``, whose space :class:`~estimators.slam_group.SlamGroup` takes
    a batch axis; recorded in the world chart, :func:`~slam.mapping.problem.world_belief`)
    only; nearest-neighbour association (whose slots depend on each run's own estimates),
    local mode and the other variants run per run, through ``run_problem``.

Every result is what ``run_problem`` returns for that run (``tests/slam/test_batch_campaign.py``):
a failing run ends alone with the per-run reason (:func:`estimators.batch.advance`).
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
from slam.mapping.problem import (
    SlamProblem,
    SlamResult,
    _chart_prior,
    _JointSteps,
    run_problem,
    world_belief,
)

__all__ = ["run_problems", "step_groups"]


def step_groups(problems: Sequence[SlamProblem], batched: bool) -> list[list[int]]:
    """The problems that may share batches: all of them (epochs and layouts are regrouped
    epoch by epoch), or each alone when ``batched`` is false."""
    if not batched:
        return [[i] for i in range(len(problems))]
    return [list(range(len(problems)))]


def run_problems(problems: Sequence[SlamProblem], filter_name: str, *, mode: str = "joint",
                 association: str = "known", gates: tuple[float, float] = (4.0, 25.0),
                 diverge_m: float = 50.0, filter_params: dict | None = None,
                 batched: bool = True) -> list[SlamResult]:
    """:func:`~slam.mapping.problem.run_problem` of each problem, runs with the same epochs
    as one batch regrouped by layout epoch by epoch (module docstring); ``batched=False``
    runs each alone."""
    kw = dict(mode=mode, association=association, gates=gates, diverge_m=diverge_m,
              filter_params=filter_params)
    base = filter_name.partition("-")[0]
    can = (batched and mode == "joint" and association == "known"
           and all(p.batchable for p in problems) and make_filter(base).batched)
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
    """``(matched (slot, offset), new offsets, late (slot, offset), slot ids after)`` of
    ``problem``'s observations at ``step`` for a state holding ``slot_ids`` (known ids,
    Bailey's order: the per-run association's)."""
    sl = problem.observations.get(step)
    ids = list(slot_ids)
    if sl is None:
        return [], [], [], ids
    slot_of = {lid: s for s, lid in enumerate(ids)}
    n_before = len(ids)
    matched, new, late = [], [], []
    for i, lid in enumerate(problem.obs_id[sl]):  # i: the offset within the step's slice
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


def _twin_classes(problems: Sequence[SlamProblem]) -> Array:
    """A class per problem: problems of one class have the same epoch steps and see the same
    landmark ids at each (so each epoch's layout key in :func:`_run_group` is the same)."""
    seen: dict[tuple, int] = {}
    out = np.empty(len(problems), dtype=int)
    for i, p in enumerate(problems):
        st = np.asarray(p.steps, dtype=np.int64)
        at = (p.observations.get(int(k)) for k in st)
        key = (st.tobytes(), *(b"" if sl is None else
                               np.asarray(p.obs_id[sl], dtype=np.int64).tobytes() for sl in at))
        out[i] = seen.setdefault(key, len(seen))
    return out


def _twins(classes: Array) -> list[list[int]]:
    """The positions of each class in ``classes``, in order of first appearance."""
    if classes.size and classes.min() == classes.max():
        return [list(range(classes.size))]
    out: dict[int, list[int]] = {}
    for j, c in enumerate(classes.tolist()):
        out.setdefault(c, []).append(j)
    return list(out.values())


def _stack_inputs(inputs: list[Any]) -> Any:
    """The members' inputs as one batch: arrays stacked, tuples of arrays stacked part by
    part."""
    if isinstance(inputs[0], tuple):
        return tuple(np.stack([np.asarray(u[i]) for u in inputs]) for i in range(len(inputs[0])))
    return np.stack([np.asarray(u) for u in inputs])


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
    ops = _JointSteps(filt, p0)  # its predict; updates build each member group's model
    lay = p0.layout
    nv, nvt = lay.vehicle_ambient, lay.vehicle_dim
    steps = [np.asarray(p.steps) for p in problems]
    n_ep = np.array([len(st) for st in steps])
    B, E = len(problems), int(n_ep.max())
    rows = np.arange(nvt) if p0.record_rows is None else np.asarray(p0.record_rows)
    poses = np.full((B, E, nv), np.nan)
    covs = np.full((B, E, len(rows), len(rows)), np.nan)
    var = np.full((B, E, nvt), np.nan)
    obs = [np.asarray(p.obs, dtype=float) for p in problems]
    obs_all = np.stack(obs) if len({o.shape for o in obs}) == 1 else None
    truth = None if p0.truth is None else [np.asarray(p.truth, dtype=float) for p in problems]
    same = truth is not None and len({t.shape for t in truth}) == 1
    truth_all = np.stack(truth) if same else None  # type: ignore[arg-type]
    maps = BatchMapRecorder(lay, B, E, p0.true_landmarks)
    runs = BatchRuns(B)
    final_ids: list[list[int]] = [[] for _ in range(B)]
    twin = _twin_classes(problems)

    def transition(e: int, b: Belief, live: Array):
        k0, k1 = int(steps[live[0]][e - 1]), int(steps[live[0]][e])
        if p0.motion_model is not None:  # built along the batch of beliefs
            u = _stack_inputs([problems[r].motion_input(k0, k1) for r in live])
            return p0.motion_model(k0, k1, b, u), u
        model, _ = p0.motion(k0, k1, None)  # type: ignore[arg-type]
        u = np.stack([np.asarray(problems[r].motion(k0, k1, None)[1])  # type: ignore[arg-type]
                      for r in live])
        return model, u

    def check(e: int, b: Belief, live: Array) -> None:
        if truth is None:
            return
        k1, d = int(steps[live[0]][e]), p0.position_dims
        at = (truth_all[live, k1, :d] if truth_all is not None
              else np.stack([truth[r][k1, :d] for r in live]))
        err = np.linalg.norm(b.mean[:, :d] - at, axis=1)
        for j in np.flatnonzero(err > diverge_m):
            if len(live) == 1:
                raise Divergence(f"vehicle error above {diverge_m} m at step {k1} "
                                 f"(position error {err[j]:.3g} m)")
            raise Divergence("a member left its bounds")  # found member by member

    def hooks(structure: tuple[list, list, list, list[int]], n_before: int, k: int):
        matched, new, late, ids = structure
        def gather(live: Array, index: Array) -> tuple[Array, Array]:
            """The members' observations (B, k·dz) at the offsets ``index`` within their
            own slice of step ``k`` (runs' observation arrays differ in length)."""
            starts = [problems[r].observations[k].start or 0 for r in live]
            if obs_all is not None:  # one gather for all members
                z = obs_all[live[:, None], np.add.outer(starts, index)]
            else:
                z = np.stack([obs[r][s + index] for r, s in zip(live, starts)])
            return z.reshape(len(live), -1), starts[0] + index

        def correct(e: int, b: Belief, live: Array) -> tuple[Belief, list[Innovation]]:
            inns = []
            if matched:
                slots, index = (np.array(v) for v in zip(*matched))
                z, at = gather(live, index)
                b, inn = filt.update(b, problems[int(live[0])].observe(slots, at), z)
                inns.append(inn)
            if new:
                z, at = gather(live, np.array(new))
                b = filt.predict(b, problems[int(live[0])].augment(n_before, z[0], at), z)
            if late:
                slots, index = (np.array(v) for v in zip(*late))
                z, at = gather(live, index)
                b, inn = filt.update(b, problems[int(live[0])].observe(slots, at), z)
                inns.append(inn)
            return b, inns


        def record(e: int, b: Belief, live: Array) -> None:
            b = world_belief(b)
            poses[live, e] = b.mean[:, :nv]
            covs[live, e] = b.cov_block(rows)
            var[live, e] = (np.sum(b.sqrt[:, :nvt] ** 2, axis=2)
                            if isinstance(b, SqrtGaussian)
                            else np.diagonal(b.cov, axis1=1, axis2=2)[:, :nvt])
            maps.record(e, b, live, ids)

        return (transition, correct, record, check)

    cohorts: list[tuple[Belief, Array, list[int]]] = [(_initial(filt, problems), np.arange(B),
                                                       [])]
    finals: dict[int, Belief] = {}
    with np.errstate(divide="raise", over="raise", invalid="raise", under="ignore"):
        for e in range(E):
            parts: dict[tuple[int, ...], list[tuple[Belief, Array]]] = {}
            for b, live, ids in cohorts:
                by_layout: dict[tuple[int, ...], list[int]] = {}
                for js in _twins(twin[live]):  # the same steps and ids: one key
                    r = live[js[0]]
                    if e >= n_ep[r]:  # the runs have ended: their beliefs are final
                        for j in js:
                            finals[int(live[j])] = member(b, j)
                            final_ids[live[j]] = ids
                        continue
                    k = int(steps[r][e])
                    sl = problems[r].observations.get(k)
                    key = (k, int(steps[r][e - 1]) if e else -1,
                           *(() if sl is None else (int(i) for i in problems[r].obs_id[sl])))
                    by_layout.setdefault(key, []).extend(js)
                for key, js in by_layout.items():
                    js.sort()  # the members in the cohort's order
                    sub, lv = (b, live) if len(js) == len(live) else (take(b, js), live[js])
                    structure = _structure(problems[int(lv[0])], key[0], ids)
                    for r in lv:
                        final_ids[r] = ids
                    h = hooks(structure, len(ids), key[0])

                    def step(e: int, bb: Belief, lv: Array, h=h) -> Belief:
                        return runs.epoch(ops, h, e, bb, lv)

                    sub, lv = advance(runs, step, e, sub, lv)
                    if lv.size:
                        parts.setdefault(tuple(structure[3]), []).append((sub, lv))
            cohorts = [(p[0][0] if len(p) == 1 else stack([x[0] for x in p]),
                        np.concatenate([x[1] for x in p]), list(key))
                       for key, p in parts.items()]
    for b, live, ids in cohorts:
        for j, r in enumerate(live):
            finals[int(r)] = member(b, j)
            final_ids[r] = ids
    out = []
    for r, res in enumerate(runs.results(finals)):
        b = world_belief(res.belief)
        n_lm, nla, nl = lay.n_landmarks(b.dim), lay.landmark_ambient, lay.landmark_dim
        lm = b.mean[nv:nv + nla * n_lm].reshape(n_lm, nla)
        lm_cov = np.array([b.cov_block(p0.landmark_rows(s)) for s in range(n_lm)]
                          ).reshape(n_lm, nl, nl)
        ids = np.array(final_ids[r][:n_lm], dtype=int)
        m = n_ep[r]
        out.append(SlamResult(filter_name, steps[r], poses[r, :m], covs[r, :m], ids, lm, lm_cov,
                              res.epochs_done, res.nis_epoch, var[r, :m], maps.series(r, m),
                              nis=res.nis, nis_dof=res.nis_dof,
                              time_s=max(res.time_s - maps.seconds / B, 0.0),
                              diverged=res.diverged, failure=res.failure))
    return out
