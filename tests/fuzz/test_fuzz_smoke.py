"""Smoke tests of the fuzz harness (``benchmarks/fuzz``).

A fixed-seed sample of 4 cheap cases: two run through the real ``slam`` command as the
harness runs cases (subprocesses, about 2 s of CPU), two - and the issue's three hostile
inputs - through the same command line in this process, classified the same way; the
classifier, the TOML writer and the mutators are also tested on their own.
``SLAM_FUZZ_CMD`` (e.g. ``"env PYTHONPATH=/some/checkout .venv/bin/slam"``) picks the CLI
to run; by default it is the ``slam`` next to the interpreter.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shlex
import time
import tomllib
import traceback
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import slam.cli
from benchmarks.fuzz import tomlio
from benchmarks.fuzz.core import Base, Case
from benchmarks.fuzz.harness import (
    CLASSES,
    GOOD,
    Limits,
    Outcome,
    classify,
    command,
    default_slam,
    run_case,
    write_case,
)
from benchmarks.fuzz.mutate import (
    LOG_FAMILIES,
    WORLD_FAMILIES,
    load_bases,
    load_log_lines,
    log_cases,
    render,
    world_cases,
)

ROOT = Path(__file__).resolve().parents[2]
TEXT_FAMILIES = {"binary", "syntax", "nesting", "long-dotted-key"}  # not parsed here (broken on
# purpose, or too costly to parse: a 30 000-part key)
SAMPLE_FAMILIES = ["delete-key", "wrong-type", "nonfinite", "syntax"]
LIMITS = Limits(seconds=25.0)


@pytest.fixture(scope="module")
def bases() -> list[Base]:
    """The bundled worlds as the fuzzer starts from them, bailey's route cut to its first
    four waypoints (a quarter lap: the sample's three bailey runs take well under a second)."""
    out = []
    for base in load_bases(ROOT / "worlds"):
        if base.name == "bailey":
            cut = {**base.doc["map"], "waypoints": base.doc["map"]["waypoints"][:4]}
            base = replace(base, doc={**base.doc, "map": cut})
        out.append(base)
    return out


@pytest.fixture(scope="module")
def log_lines() -> list[str]:
    return load_log_lines(n=120)


def _slam() -> list[str]:
    given_cmd = os.environ.get("SLAM_FUZZ_CMD")
    return shlex.split(given_cmd) if given_cmd else default_slam()


def _by_name(bases: list[Base], name: str) -> Base:
    return next(b for b in bases if b.name == name)


def _regressions(bailey: Base, log_lines: list[str]) -> list[Case]:
    """Three hostile inputs from the issue that are quick to run."""
    deep = "deep = " + "[" * 1000 + "0" + "]" * 1000 + "\n" + tomlio.dumps(bailey.doc)
    doc = json.loads(json.dumps(bailey.doc))
    doc["sensor"]["sigma_range_m"] = 1e-308
    lines = list(log_lines)
    k = next(i for i, ln in enumerate(lines) if ln.startswith("LANDMARK"))
    t = lines[k].split()
    lines[k] = " ".join([*t[:3], "0", "0", *t[5:]])
    return [render(bailey, "nesting", "arrays 1000 deep at the top level", text=deep),
            render(bailey, "extreme", "sensor.sigma_range_m = 1e-308", doc),
            Case("log", "log-geometry", f"line {k + 1}: landmark at range 0", "victoria",
                 ("\n".join(lines) + "\n").encode())]


def _in_process(case: Case, folder: Path) -> Outcome:
    """Run ``case`` with the harness's arguments through ``slam.cli.main`` in this process
    (cwd ``folder``) and classify it as the harness classifies a subprocess: an exception
    that escapes the command line becomes the traceback it would have printed."""
    target = write_case(case, folder)
    out = Path("out")
    t0 = time.perf_counter()
    with contextlib.chdir(folder):
        res = CliRunner().invoke(slam.cli.main, command([], case, target, out))
    stderr = res.stderr
    if res.exc_info is not None and not isinstance(res.exc_info[1], SystemExit):
        stderr += "".join(traceback.format_exception(*res.exc_info))
    written = sorted(str(p.relative_to(folder)) for p in (folder / out).rglob("*"))
    names = [target.name, str(target)] if case.target is None else [str(target)]
    klass, detail = classify(res.exit_code, stderr, written, folder / out / "summary.json",
                             names)
    return Outcome(case, klass, res.exit_code, time.perf_counter() - t0, detail,
                   stderr[-4000:], written)


@pytest.fixture(scope="module")
def sample(bases: list[Base], log_lines: list[str], tmp_path_factory: pytest.TempPathFactory
           ) -> dict[str, list[Outcome]]:
    """Run the fixed sample once: a known-good world and one mutated cheap world as the
    harness runs cases (``slam`` subprocesses, two at a time), a world with an unknown key
    and one mutated log through the same command line in this process (the long campaigns
    are `python -m benchmarks.fuzz`)."""
    cheap = [_by_name(bases, "bailey"), _by_name(bases, "star-sensor")]
    good = render(cheap[0], "control", "unmodified")
    doc = json.loads(json.dumps(cheap[0].doc))
    doc["vehicle"]["speed_mpss"] = 3.0
    unknown = render(cheap[0], "control", "unknown key vehicle.speed_mpss", doc)
    mutated = world_cases(1, 0, cheap, SAMPLE_FAMILIES)
    logs = log_cases(1, 0, log_lines, ["log-number"])
    work = tmp_path_factory.mktemp("fuzz")
    slam = _slam()
    with ThreadPoolExecutor(max_workers=2) as pool:
        spawned = list(pool.map(lambda ic: run_case(ic[1], work, slam, LIMITS,
                                                    folder_name=str(ic[0])),
                                enumerate([good, *mutated])))
    here = [_in_process(c, work / f"in-{i}") for i, c in enumerate([unknown, *logs])]
    return {"control": [spawned[0], here[0]], "sample": [*spawned[1:], *here[1:]]}


@pytest.fixture(scope="module")
def regressions(bases: list[Base], log_lines: list[str],
                tmp_path_factory: pytest.TempPathFactory) -> list[Outcome]:
    """The issue's three hostile inputs through the same command line, in this process."""
    work = tmp_path_factory.mktemp("regressions")
    cases = _regressions(_by_name(bases, "bailey"), log_lines)
    return [_in_process(c, work / str(i)) for i, c in enumerate(cases)]


def _why(o: Outcome) -> str:
    return f"{o.case.family}/{o.case.base} {o.case.name}: {o.klass} ({o.detail})"


# --------------------------------------------------------------------------- through the CLI

def test_known_good_world_is_ok(sample: dict[str, list[Outcome]]) -> None:
    good = sample["control"][0]
    assert good.klass == "ok", _why(good) + "\n" + good.stderr_tail


def test_unknown_key_is_rejected(sample: dict[str, list[Outcome]]) -> None:
    bad = sample["control"][1]
    assert bad.klass == "rejected", _why(bad) + "\n" + bad.stderr_tail
    assert "speed_mpss" in bad.detail


def test_sample_is_classified(sample: dict[str, list[Outcome]],
                              regressions: list[Outcome]) -> None:
    outcomes = sample["sample"] + regressions
    assert len(outcomes) == 5
    assert all(o.klass in CLASSES for o in outcomes)
    assert all(o.seconds <= LIMITS.seconds + 5 for o in outcomes)


def test_sample_has_no_traceback(sample: dict[str, list[Outcome]]) -> None:
    bad = [o for o in sample["sample"] if o.klass not in GOOD]
    assert not bad, "\n".join(map(_why, bad))


def test_issue_regressions_have_no_traceback(regressions: list[Outcome]) -> None:
    bad = [o for o in regressions if o.klass not in GOOD]
    assert not bad, "\n".join(map(_why, bad))


# --------------------------------------------------------------------------- classifier

def test_classifier_classes(tmp_path: Path) -> None:
    missing = tmp_path / "none.json"
    named = ["case.toml"]
    one = "error: case.toml: [vehicle] x: unknown key\n"
    assert classify(None, "", [], missing, named)[0] == "hang"
    assert classify(1, "Traceback (most recent call last):\nValueError: x\n", [], missing,
                    named) == ("traceback", "ValueError: x")
    assert classify(1, "MemoryError\n", [], missing, named)[0] == "memory"
    assert classify(-11, "", [], missing, named)[0] == "crash"
    assert classify(2, one, [], missing, named)[0] == "rejected"
    assert classify(2, one, ["out/summary.json"], missing, named)[0] == "wrote-on-error"
    assert classify(2, one + "more\n", [], missing, named)[0] == "multi-line-error"
    assert classify(2, "error: something\n", [], missing, named)[0] == "unnamed-error"
    assert classify(0, "", [], missing, named)[0] == "degenerate-success"


def _summary(tmp_path: Path, entry: dict) -> Path:
    path = tmp_path / "summary.json"
    path.write_text(json.dumps({"filters": {"srckf": entry}}))
    return path


def test_classifier_degenerate_scores(tmp_path: Path) -> None:
    real = {"runs_scored": 1, "pos_rmse_m": 0.6, "pos_err_range_m": {"x": [-1.0, 0.4]}}
    zero = {"runs_scored": 1, "pos_rmse_m": 0.0, "pos_err_range_m": {"x": [0.0, 0.0]}}
    unscored = {"runs_scored": 0, "pos_rmse_m": 0.6}
    assert classify(0, "", [], _summary(tmp_path, real), [])[0] == "ok"
    for entry in (zero, unscored, {**real, "anees": math.nan}):
        assert classify(0, "", [], _summary(tmp_path, entry), [])[0] == "degenerate-success"


# --------------------------------------------------------------------------- mutators

# st.characters(): the utf-8-encodable set, without the codec table hypothesis builds
# once per checkout (seconds)
_scalars = (st.integers(-(2**63), 2**63 - 1) | st.booleans() | st.text(st.characters(), max_size=8)
            | st.floats(allow_nan=False))
_keys = st.text(st.characters(), min_size=1, max_size=6)
_docs = st.dictionaries(_keys, st.recursive(
    _scalars, lambda inner: st.lists(inner, max_size=3)
    | st.dictionaries(_keys, inner, min_size=1, max_size=3), max_leaves=8), max_size=5)


@given(_docs)
@settings(max_examples=60, deadline=None, database=None)
def test_toml_writer_round_trips(doc: dict) -> None:
    assert tomllib.loads(tomlio.dumps(doc)) == doc


@given(family=st.sampled_from(sorted(WORLD_FAMILIES)), seed=st.integers(0, 2**32))
@settings(max_examples=25, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
def test_world_mutators(bases: list[Base], family: str, seed: int) -> None:
    first = world_cases(3, seed, bases, [family])
    assert first == world_cases(3, seed, bases, [family])  # deterministic for a seed
    for case in first:
        assert case.family == family and case.name and case.data is not None
        base = _by_name(bases, case.base)
        plain = render(base, "", "")
        assert (case.data, case.extra) != (plain.data, plain.extra)  # something changed
        if family not in TEXT_FAMILIES:
            doc = tomllib.loads(case.data.decode("utf-8"))  # parseable ...
            mutated = tomlio.dumps(doc) != tomlio.dumps(base.doc)  # (3 != 3.0 here)
            assert mutated or case.extra != plain.extra  # ... and mutated


@given(family=st.sampled_from(sorted(LOG_FAMILIES)), seed=st.integers(0, 2**32))
@settings(max_examples=40, deadline=None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_log_mutators(log_lines: list[str], family: str, seed: int) -> None:
    first = log_cases(3, seed, log_lines, [family])
    assert first == log_cases(3, seed, log_lines, [family])
    base = ("\n".join(log_lines) + "\n").encode()
    for case in first:
        assert isinstance(case, Case) and case.family == family and case.name
        assert (case.target is not None) != (case.data is not None)
        assert case.data != base


@pytest.mark.parametrize("path", sorted((Path(__file__).parents[2] / "worlds").glob("*.toml")),
                         ids=lambda p: p.stem)
def test_every_cheapened_base_is_a_valid_world(path: Path) -> None:
    """The harness mutates cheapened bundled worlds: a base the validator refuses would
    make every mutation of it a trivial rejection (as ship's once was)."""
    from benchmarks.fuzz.core import cheapen
    from slam.registry import world_from_dict

    doc = cheapen(tomllib.loads(path.read_text(encoding="utf-8")))
    w = world_from_dict(doc, name=path.stem, base=path.parent)
    assert len(w.filters.names) == 1
