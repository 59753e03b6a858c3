r"""An external scenario kind for ``slam``: a target on a line (position, velocity), white-noise
acceleration of density q, position fixes of σ; Kalman-type filters from
:func:`estimators.make_filter` on :math:`\mathbb{R}^2`, scored by RMSE and NEES against the
χ² band.  Installed, it is found through the ``navfilters.kinds`` entry point and its worlds
through ``navfilters.worlds``: ``slam worlds`` lists ``line``, ``slam run line`` runs it.
(No smoother: the Kalman filter is this problem's optimum.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from estimators import Euclidean, Measurement, Noise, Transition, make_filter
from slam.kind import Kind
from slam.render.document import KindReport, Section
from slam.render.tables import anees_cell, num, plain_table, verdict
from slam.results import RunOutcome
from slam.scoring import anees_entries
from worlds import limits
from worlds import schema as ws

NAME = "cv-tracker-1d"
FILTERS = ("ekf", "ckf", "srckf")  # no tuning constants to state


@dataclass(frozen=True)
class Filters:
    names: tuple[str, ...]


@dataclass(frozen=True)
class World:
    name: str
    source: str
    kind: str
    description: str
    runs: int
    seed: int
    steps: int
    dt_s: float
    q: float
    sigma: float
    p0: tuple[float, float]
    filters: Filters


SCHEMA: dict[str, Any] = {
    "kind": ws.String(choices=(NAME,)),
    "description": ws.String(one_line=True),
    "runs": ws.Integer(ws.Interval(1, 10_000)),
    "seed": ws.Integer(ws.Interval(0, 2**32 - 1), default=0),
    "steps": ws.Integer(ws.Interval(1, 100_000)),
    "dt_s": ws.Number(ws.positive(10.0)),
    "motion": ws.Section({"accel_density_m2_s3": ws.Number(ws.positive(100.0))}),
    "sensor": ws.Section({"sigma_pos_m": ws.Number(ws.positive(1000.0))}),
    "initial": ws.Section({"sigma_pos_m": ws.Number(ws.positive(1000.0)),
                           "sigma_vel_mps": ws.Number(ws.positive(100.0))}),
    "filters": ws.Section({"names": ws.StringList(FILTERS)}),
}


def parse(data: dict[str, Any], name: str, source: str, base: Any) -> World:
    v = ws.read_table(data, SCHEMA, ws.Where(source, ""))
    return World(name, source, NAME, v["description"], v["runs"], v["seed"], v["steps"],
                 v["dt_s"], v["motion"]["accel_density_m2_s3"], v["sensor"]["sigma_pos_m"],
                 (v["initial"]["sigma_pos_m"], v["initial"]["sigma_vel_mps"]),
                 Filters(v["filters"]["names"]))


def work(w: World):
    yield limits.Size("samples", "steps", w.steps, "steps")
    yield limits.Size("epochs", "filter epochs", w.steps + 1, "steps")
    yield limits.Size("state", "state dimensions", 2, None)
    yield limits.Size("work", "units of filter work", limits.filter_work(w.steps + 1, w.steps,
                                                                         2, 2), "steps")


@dataclass(frozen=True)
class Scores:
    name: str
    err: np.ndarray  # (K, 2)
    nees: np.ndarray  # (K,)
    diverged: bool = False
    failure: str | None = None


def run_once(w: World, run: int, seed_seq: np.random.SeedSequence, filters, keep_tracks=False
             ) -> RunOutcome:
    rng = np.random.default_rng(seed_seq)
    F = np.array([[1.0, w.dt_s], [0.0, 1.0]])
    Q = w.q * np.array([[w.dt_s**3 / 3, w.dt_s**2 / 2], [w.dt_s**2 / 2, w.dt_s]])
    P0, R = np.diag(np.square(w.p0)), np.array([[w.sigma**2]])
    x = rng.multivariate_normal(np.zeros(2), P0)
    truth, z = [], []
    for _ in range(w.steps):
        x = F @ x + rng.multivariate_normal(np.zeros(2), Q)
        truth.append(x)
        z.append(x[:1] + rng.normal(0.0, w.sigma, 1))
    move = Transition(lambda X, u: X @ F.T, Noise.from_cov(Q), jacobian=lambda x, u: F)
    fix = Measurement(lambda X: X[..., :1], Noise.from_cov(R),
                      jacobian=lambda x: np.array([[1.0, 0.0]]))
    scores = {}
    for name in filters:
        flt = make_filter(name)
        b = flt.init(np.zeros(2), Euclidean(2), cov=P0)
        err, nees = np.empty((w.steps, 2)), np.empty(w.steps)
        for k in range(w.steps):
            b, _ = flt.update(flt.predict(b, move), fix, z[k])
            err[k] = b.mean - truth[k]
            nees[k] = err[k] @ np.linalg.solve(b.cov, err[k])
        scores[name] = Scores(name, err, nees)
    return RunOutcome(run, scores)


def summarize(w: World, outcomes: list[RunOutcome], filters, runs: int, seed: int) -> dict:
    out: dict[str, Any] = {"world": w.name, "kind": NAME, "runs": runs, "seed": seed,
                           "filters": {}}
    for name in filters:
        s = [o.scores[name] for o in outcomes]
        err = np.stack([x.err for x in s])
        e = {"runs_scored": len(s), "pos_rmse_m": float(np.sqrt(np.mean(err[..., 0] ** 2))),
             **anees_entries(np.stack([x.nees for x in s]), 2)}
        e["consistency"] = verdict(e)
        out["filters"][name] = e
    return out


HEADER = ("filter", "pos RMSE (m)", "ANEES [95 % band]", "verdict")


def rows(summary: dict) -> list[list[str]]:
    return [[n, num(e["pos_rmse_m"], ".3f"), anees_cell(e), e["consistency"]]
            for n, e in summary["filters"].items()]


REPORT = KindReport("1-D constant-velocity tracking (plug-in kind)",
                    lambda s: [Section("Results", HEADER, rows(s))], lambda: {},
                    lambda s: plain_table(HEADER, rows(s)))
KIND = Kind(NAME, parse, run_once, summarize, REPORT, filters=FILTERS, work=work)
