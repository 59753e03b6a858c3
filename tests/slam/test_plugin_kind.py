"""A scenario kind defined entirely in this file runs end to end through ``slam run``.

The kind - a 1-D constant-velocity tracker - is a world schema (the :mod:`worlds.schema`
engine), a simulator, a Kalman filter through :func:`estimators.make_filter` on
``Euclidean(2)``, NEES scoring, a summary and a one-section
:class:`~slam.render.document.KindReport`.  It becomes usable by one
:func:`slam.registry.register` call: the command line, the campaign runner and the renderer
are not touched, which is the claim of :mod:`slam.kind` ("adding a kind is one folder plus
one registration") tested from outside the package.

The model is linear and Gaussian and the filters assume the true noises, so the Kalman
filter is exactly consistent: at each step the run-averaged NEES over ``R`` runs, divided
by the 2 state dof, is distributed as :math:`\\chi^2_{2R}/(2R)`.  The test checks the
campaign's ANEES against that band (:func:`slam.scoring.anees_band`) and, to show the
check can fail, that a filter assuming 1/100 of the process noise lands far above it.
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

import slam.cli
from estimators import Euclidean, Measurement, Noise, Transition, make_filter
from slam.campaign import run_campaign
from slam.kind import Kind
from slam.registry import KINDS, register, world_from_dict
from slam.render.document import KindReport, Section
from slam.render.tables import anees_cell, num, plain_table
from slam.results import RunOutcome
from slam.scoring import anees_band
from worlds import WorldError, limits
from worlds import schema as ws

NAME = "cv-tracker-1d"
DOF = 2
TRACKER_FILTERS = ("ekf", "ckf", "ukf", "srckf", "srukf", "srcdkf")  # exact on a linear model

# --------------------------------------------------------------------------- world


@dataclass(frozen=True)
class TrackerFilters:
    names: tuple[str, ...]
    process_noise_scale: float  # the filters assume scale x the true acceleration density


@dataclass(frozen=True)
class TrackerWorld:
    """A target on a line: position and velocity, white-noise acceleration, position fixes."""

    name: str
    source: str
    kind: str
    description: str
    runs: int
    seed: int
    steps: int
    dt_s: float
    accel_density: float  # q, (m/s^2)^2 / Hz: Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]
    sigma_pos_m: float
    initial_sigma_pos_m: float
    initial_sigma_vel_mps: float
    filters: TrackerFilters


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
    "filters": ws.Section({"names": ws.StringList(TRACKER_FILTERS),
                           "process_noise_scale": ws.Number(ws.positive(1e6), default=1.0)}),
}


def parse(data: dict[str, Any], name: str, source: str, base: Any) -> TrackerWorld:
    """Validate a ``cv-tracker-1d`` world document (errors name the file and the key)."""
    v = ws.read_table(data, SCHEMA, ws.Where(source, ""))
    return TrackerWorld(
        name=name, source=source, kind=NAME, description=v["description"], runs=v["runs"],
        seed=v["seed"], steps=v["steps"], dt_s=v["dt_s"],
        accel_density=v["motion"]["accel_density_m2_s3"],
        sigma_pos_m=v["sensor"]["sigma_pos_m"],
        initial_sigma_pos_m=v["initial"]["sigma_pos_m"],
        initial_sigma_vel_mps=v["initial"]["sigma_vel_mps"],
        filters=TrackerFilters(v["filters"]["names"], v["filters"]["process_noise_scale"]))


def work(w: TrackerWorld):
    """One run: ``steps`` samples and filter epochs of a 2-state filter (2 noise inputs)."""
    yield limits.Size("samples", "steps", w.steps, "steps")
    yield limits.Size("epochs", "filter epochs", w.steps + 1, "steps")
    yield limits.Size("state", "state dimensions", DOF, None)
    yield limits.Size("work", "units of filter work",
                      limits.filter_work(w.steps + 1, w.steps, DOF, DOF), "steps")


# --------------------------------------------------------------------------- model, simulator


def matrices(w: TrackerWorld) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``F``, ``Q`` (true), ``P0`` and ``R`` of the world."""
    dt, q = w.dt_s, w.accel_density
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = q * np.array([[dt**3 / 3.0, dt**2 / 2.0], [dt**2 / 2.0, dt]])
    P0 = np.diag([w.initial_sigma_pos_m**2, w.initial_sigma_vel_mps**2])
    return F, Q, P0, np.array([[w.sigma_pos_m**2]])


def simulate(w: TrackerWorld, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Truth ``(K + 1, 2)`` (the start drawn from the filters' prior) and fixes ``(K, 1)``."""
    F, Q, P0, R = matrices(w)
    x = np.empty((w.steps + 1, 2))
    x[0] = rng.multivariate_normal(np.zeros(2), P0)
    for k in range(w.steps):
        x[k + 1] = F @ x[k] + rng.multivariate_normal(np.zeros(2), Q)
    z = x[1:, :1] + rng.normal(0.0, w.sigma_pos_m, (w.steps, 1))
    return x, z


@dataclass(frozen=True)
class TrackScores:
    name: str
    err: np.ndarray  # (K, 2) estimate - truth after each update
    nees: np.ndarray  # (K,)
    nis: np.ndarray  # (K,)


def run_filter(w: TrackerWorld, name: str, z: np.ndarray, truth: np.ndarray) -> TrackScores:
    F, Q, P0, R = matrices(w)
    H = np.array([[1.0, 0.0]])
    tr = Transition(lambda X, u: X @ F.T, Noise.from_cov(Q * w.filters.process_noise_scale),
                    jacobian=lambda x, u: F)
    me = Measurement(lambda X: X[:, :1], Noise.from_cov(R), jacobian=lambda x: H)
    flt = make_filter(name)
    b = flt.init(np.zeros(2), Euclidean(2), cov=P0)
    err, nees, nis = np.empty((w.steps, 2)), np.empty(w.steps), np.empty(w.steps)
    for k in range(w.steps):
        b = flt.predict(b, tr)
        b, inn = flt.update(b, me, z[k])
        e = b.mean - truth[k + 1]
        err[k], nees[k], nis[k] = e, e @ np.linalg.solve(b.cov, e), inn.nis
    return TrackScores(name, err, nees, nis)


def run_once(world: TrackerWorld, run: int, seed_seq: np.random.SeedSequence,
             filters: list[str], keep_tracks: bool = False) -> RunOutcome:
    truth, z = simulate(world, np.random.default_rng(seed_seq))
    return RunOutcome(run, {n: run_filter(world, n, z, truth) for n in filters})


def summarize(world: TrackerWorld, outcomes: list[RunOutcome], filters: list[str], runs: int,
              seed: int) -> dict:
    lo, hi = anees_band(runs, DOF)
    out: dict[str, Any] = {"world": world.name, "kind": NAME, "runs": runs, "seed": seed,
                           "steps": world.steps, "filters": {}}
    for name in filters:
        s = [o.scores[name] for o in outcomes]
        err = np.stack([x.err for x in s])
        per_step = np.mean([x.nees for x in s], axis=0) / DOF  # (K,) run-averaged NEES / dof
        out["filters"][name] = {
            "runs_scored": len(s),
            "pos_rmse_m": float(np.sqrt(np.mean(err[..., 0] ** 2))),
            "vel_rmse_mps": float(np.sqrt(np.mean(err[..., 1] ** 2))),
            "anees": float(per_step.mean()),
            "anees_bounds_95": [lo, hi],
            "anees_steps_inside_95": float(np.mean((per_step >= lo) & (per_step <= hi))),
            "anees_last_step": float(per_step[-1]),
            "nis_mean": float(np.mean([x.nis for x in s])),
        }
    return out


# --------------------------------------------------------------------------- report

HEADER = ("filter", "pos RMSE (m)", "vel RMSE (m/s)", "ANEES [95 % band]", "steps in band")


def rows(summary: dict[str, Any]) -> list[list[str]]:
    return [[name, num(e["pos_rmse_m"], ".3f"), num(e["vel_rmse_mps"], ".3f"), anees_cell(e),
             num(e["anees_steps_inside_95"], ".0%")] for name, e in summary["filters"].items()]


def sections(summary: dict[str, Any]) -> list[Section]:
    return [Section("Tracking results", HEADER, rows(summary),
                    "NEES of the 2-dof state, run-averaged per step and divided by 2; the "
                    "band is the two-sided 95 % band of that average for a consistent filter.")]


REPORT = KindReport(what="1-D constant-velocity tracking", sections=sections,
                    figures=lambda: {}, text_table=lambda s: plain_table(HEADER, rows(s)))
TRACKER = Kind(NAME, parse, run_once, summarize, REPORT, work=work)

WORLD_TOML = """\
kind = "cv-tracker-1d"
description = "Plug-in test: a target on a line, white-noise acceleration, position fixes"
runs = 60
seed = 11
steps = 80
dt_s = 0.1

[motion]
accel_density_m2_s3 = 0.5

[sensor]
sigma_pos_m = 1.0

[initial]
sigma_pos_m = 2.0
sigma_vel_mps = 1.0

[filters]
names = ["ekf", "srckf"]
"""


@pytest.fixture
def tracker_kind(monkeypatch) -> Kind:
    """The kind registered the way a plug-in registers itself: one ``register`` call.
    The ``setitem`` before it only makes monkeypatch record that the registry had no
    such kind, so that the kind is removed again after the test."""
    assert NAME not in KINDS
    monkeypatch.setitem(KINDS, NAME, None)
    assert register(TRACKER) is TRACKER and KINDS[NAME] is TRACKER
    return TRACKER


def test_a_kind_defined_in_a_test_runs_through_the_cli(tracker_kind, tmp_path):
    world_file = tmp_path / "line.toml"
    world_file.write_text(WORLD_TOML, encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(world_file), "--workers", "1",
                                             "--out", str(out)])
    assert res.exit_code == 0, res.output
    # the terminal table is the kind's own
    assert re.search(r"^filter\s+pos RMSE \(m\)", res.output, re.M)
    assert re.search(r"^ekf\s+\d+\.\d{3}\s", res.output, re.M)
    assert re.search(r"^srckf\s+\d+\.\d{3}\s", res.output, re.M)

    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"),
                         parse_constant=lambda c: pytest.fail(f"non-strict JSON {c}"))
    assert (summary["world"], summary["kind"], summary["runs"], summary["seed"]) == (
        "line", NAME, 60, 11)
    assert list(summary["filters"]) == ["ekf", "srckf"]
    lo, hi = anees_band(60, DOF)  # chi2(120)/120: [0.76, 1.27]
    for name, e in summary["filters"].items():
        assert e["runs_scored"] == 60 and e["anees_bounds_95"] == [lo, hi]
        # consistent: the time-averaged and the last step's run-averaged NEES / dof lie in
        # the chi-square band, and so do most steps (95 % expected)
        assert lo <= e["anees"] <= hi, (name, e["anees"])
        assert lo <= e["anees_last_step"] <= hi, (name, e["anees_last_step"])
        assert e["anees_steps_inside_95"] >= 0.85, (name, e["anees_steps_inside_95"])
        assert 0.8 < e["nis_mean"] < 1.2, (name, e["nis_mean"])
        # a position fix every 0.1 s with 1 m noise and a smooth target: well below 1 m
        assert 0.2 < e["pos_rmse_m"] < 1.0, (name, e["pos_rmse_m"])
    # a linear model: the EKF and the square-root cubature filter compute the same thing
    ekf, srckf = summary["filters"]["ekf"], summary["filters"]["srckf"]
    assert math.isclose(ekf["anees"], srckf["anees"], rel_tol=1e-8)
    assert math.isclose(ekf["pos_rmse_m"], srckf["pos_rmse_m"], rel_tol=1e-8)

    # the report: the generic renderer with the kind's one section, no figures
    assert sorted(p.name for p in out.iterdir()) == [".slam-output", "report.html",
                                                     "report.md", "summary.json"]
    md = (out / "report.md").read_text(encoding="utf-8")
    assert md.startswith("# line: 1-D constant-velocity tracking\n")
    assert "Plug-in test: a target on a line" in md
    assert f"60 Monte Carlo runs, seed 11, world kind `{NAME}`" in md
    assert "## Tracking results" in md and "## Figures" not in md
    assert re.search(r"^\| srckf \| \d+\.\d{3} \|", md, re.M)
    html = (out / "report.html").read_text(encoding="utf-8")
    results, _, provenance = html.partition("<h2>Provenance</h2>")
    assert "<h2>Tracking results</h2>" in results and results.count("<tr>") == 1 + 2
    assert "<td>command line</td>" in provenance


def test_malformed_world_of_the_plugin_kind_exits_2_naming_the_key(tracker_kind, tmp_path):
    world_file = tmp_path / "bad.toml"
    world_file.write_text(WORLD_TOML.replace("sigma_pos_m = 1.0", "sigma_pos_m = -1.0"),
                          encoding="utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(world_file), "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert f"{world_file}: [sensor] sigma_pos_m = -1.0: must be in (0, 1000]" in res.output
    assert not out.exists()


def test_a_kind_must_declare_its_work_and_the_registry_checks_it(tracker_kind, monkeypatch):
    """A kind without ``work`` cannot be made or registered; a world of the plug-in kind
    over a limit is refused by the registry (the kind's own parse checks no size)."""
    with pytest.raises(TypeError, match="work"):
        Kind(NAME, parse, run_once, summarize, REPORT)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="declares no work"):
        register(Kind(NAME, parse, run_once, summarize, REPORT, work=None))  # type: ignore
    assert KINDS[NAME] is TRACKER
    big = WORLD_TOML.replace("steps = 80", "steps = 60000")
    with pytest.raises(WorldError) as err:
        world_from_dict(tomllib.loads(big), name="big", source="big.toml")
    assert str(err.value) == ("big.toml: steps = 60000: the run would need 60,001 filter "
                              "epochs; at most 50,000 are allowed")
    # a work that leaves out a required size is the kind's bug, not the world's
    def partial(w):
        yield limits.Size("samples", "steps", w.steps, "steps")
    monkeypatch.setitem(KINDS, NAME, Kind(NAME, parse, run_once, summarize, REPORT,
                                          work=partial))
    with pytest.raises(TypeError, match="states no epochs, state, work"):
        world_from_dict(tomllib.loads(WORLD_TOML), name="line")


def test_the_chi_square_check_fails_for_an_overconfident_filter(tracker_kind):
    """Filters assuming 1/100 of the true process noise trust their prediction too much:
    their ANEES lands far above the band (so the band check above can fail)."""
    text = WORLD_TOML.replace('names = ["ekf", "srckf"]',
                              'names = ["ekf"]\nprocess_noise_scale = 0.01')
    world = world_from_dict(tomllib.loads(text), name="overconfident")
    result = run_campaign(world, runs=20, workers=1)
    e = result.summary["filters"]["ekf"]
    lo, hi = anees_band(20, DOF)
    assert e["anees"] > 3 * hi and e["anees_steps_inside_95"] < 0.2, e


def test_the_plugin_kind_is_gone_after_its_tests():
    assert NAME not in KINDS
