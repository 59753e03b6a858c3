"""The issue-24 families of the fuzz harness generate reproducible cases of the intended
shape, and the classifier's new classes (no ``slam`` run here: the cases are generated
and read, the classifier is fed made-up runs, and the one subprocess is ``python -c``).
"""

from __future__ import annotations

import json
import math
import re
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest

from benchmarks.fuzz.core import Base, Case
from benchmarks.fuzz.extremes import TINY
from benchmarks.fuzz.harness import GOOD, Limits, Usage, assess, execute_usage
from benchmarks.fuzz.mutate import (
    LOG_FAMILIES,
    WORLD_FAMILIES,
    load_bases,
    load_log_lines,
    log_cases,
    world_cases,
)
from benchmarks.fuzz.schemas import NOISE, noise_keys, numeric_keys, size_keys
from benchmarks.fuzz.shapes import map_points
from benchmarks.fuzz.textual import STYLES, dotted_key_text
from benchmarks.fuzz.verdicts import null_pattern, unexplained_nulls

ROOT = Path(__file__).resolve().parents[2]
NEW_WORLD = ["underflow-sigma", "kind-size", "degenerate-path", "paper-types", "long-dotted-key"]
N = 26  # two cases per bundled base


@pytest.fixture(scope="module")
def bases() -> list[Base]:
    return load_bases(ROOT / "worlds")


@pytest.fixture(scope="module")
def cases(bases: list[Base]) -> dict[str, list[Case]]:
    return {f: world_cases(N, 7, bases, [f]) for f in NEW_WORLD}


def _base(bases: list[Base], case: Case) -> Base:
    return next(b for b in bases if b.name == case.base)


def _flat(doc: Any, path: tuple = ()) -> dict[tuple, Any]:
    """Every scalar (and every empty container) by path."""
    if isinstance(doc, dict) and doc:
        return {p: v for k, x in doc.items() for p, v in _flat(x, (*path, k)).items()}
    if isinstance(doc, list) and doc:
        return {p: v for i, x in enumerate(doc) for p, v in _flat(x, (*path, i)).items()}
    return {path: doc}


def _changed(base: Base, case: Case) -> dict[tuple, Any]:
    """The paths whose value the case changed (or added), with the new values."""
    old, new = _flat(base.doc), _flat(tomllib.loads(case.data.decode()))
    return {p: v for p, v in new.items() if p not in old or old[p] != v
            or type(old[p]) is not type(v)}


def test_new_families_are_registered_and_reproducible(bases: list[Base],
                                                      cases: dict[str, list[Case]]) -> None:
    assert set(NEW_WORLD) <= set(WORLD_FAMILIES) and "log-huge-int" in LOG_FAMILIES
    for family in NEW_WORLD:
        assert world_cases(N, 7, bases, [family]) == cases[family]
        assert {c.family for c in cases[family]} == {family}
        assert {c.base for c in cases[family]} == {b.name for b in bases}  # every base
    assert world_cases(4, 8, bases, ["kind-size"]) != world_cases(4, 7, bases, ["kind-size"])


def test_schema_finds_the_issue_keys() -> None:
    """The keys behind the issue's classes are found from the schemas, not listed."""
    noise = {k: {".".join(s.path) for s in noise_keys(k)}
             for k in ("alignment", "fixed-wing", "spinning")}
    assert "filters.velocity_sigma_mps" in noise["alignment"]
    assert "ea.roll_pitch_sigma_deg" in noise["fixed-wing"]
    # spinning's γ is a settings table's key whose range already stops at MIN_GAMMA
    from benchmarks.fuzz.schemas import numeric_keys
    from estimators.hinf import MIN_GAMMA

    gamma = [k for k in numeric_keys("spinning") if ".".join(k.path) == "filters.hinf.gamma"]
    assert len(gamma) == 1 and gamma[0].lo == MIN_GAMMA and not gamma[0].allows(1e-300)
    sizes = {k: {".".join(s.path): v for s, v in size_keys(k)}
             for k in ("alignment", "ship", "spinning")}
    assert sizes["alignment"]["imu.rate_hz"] == 10_000 and sizes["alignment"]["duration_s"] > 0
    assert sizes["ship"]["gyro.rate_hz"] == 10_000 and sizes["ship"]["duration_s"] == 86_400
    assert sizes["spinning"]["sample_interval_s"] == 0.001


def test_underflow_sigma_sets_noise_keys_tiny(bases: list[Base],
                                              cases: dict[str, list[Case]]) -> None:
    for case in cases["underflow-sigma"]:
        base = _base(bases, case)
        declared = {s.path: s for s in numeric_keys(base.kind)}
        changed = _changed(base, case)
        assert changed, case.name
        for path, v in changed.items():
            key_path = tuple(p for p in path if isinstance(p, str))
            assert NOISE.search(key_path[-1]), (case.name, path)
            assert v in TINY, (case.name, path, v)
            assert key_path not in declared or declared[key_path].allows(v), (case.name, path)


def test_kind_size_makes_runs_bigger(bases: list[Base], cases: dict[str, list[Case]]) -> None:
    for case in cases["kind-size"]:
        base = _base(bases, case)
        changed = _changed(base, case)
        assert changed, case.name
        down = {s.path for s, _ in size_keys(base.kind) if s.name.endswith("interval_s")}
        old = _flat(base.doc)
        for path, v in changed.items():
            assert path in {s.path for s, _ in size_keys(base.kind)}, (case.name, path)
            if path in old:
                assert (v <= old[path]) if path in down else (v >= old[path]), case.name
    full = [c for c in cases["kind-size"] if "every size key at the limit" in c.name]
    assert full  # the all-at-the-limit combination is drawn


def _gap(wp: list[list[float]]) -> float:
    """The shortest leg of the closed waypoint loop (inf for < 2 waypoints)."""
    loop = [*wp, wp[0]] if wp else []
    return min((math.dist(a, b) for a, b in zip(loop, loop[1:])), default=math.inf)


SECTIONS = {"spinning": {"launch", "flight", "spin"}, "fixed-wing": {"flight", "gnss", "ea",
            "scoring"}, "alignment": {"sway", "wind", "site"}, "ship": {"waves", "site"},
            "attitude": {"satellite", "scoring"}}


def test_degenerate_path_shapes(bases: list[Base], cases: dict[str, list[Case]]) -> None:
    for case in cases["degenerate-path"]:
        base = _base(bases, case)
        doc = tomllib.loads(case.data.decode())
        if base.kind in ("planar-slam", "drone-slam"):
            mutated = Base(base.name, doc, case.extra)
            _, wp = map_points(mutated, doc)
            assert _gap(wp) < 1e-6, (case.name, wp[:4])
        else:
            changed = _changed(base, case)
            assert changed and {p[0] for p in changed} <= SECTIONS[base.kind], case.name


def test_paper_types_change_only_paper(bases: list[Base], cases: dict[str, list[Case]]) -> None:
    for case in cases["paper-types"]:
        base = _base(bases, case)
        doc = tomllib.loads(case.data.decode())
        assert case.plots  # figures read [paper] too
        assert {k: v for k, v in doc.items() if k != "paper"} == \
            {k: v for k, v in base.doc.items() if k != "paper"}
        old, new = base.doc.get("paper", {}), doc["paper"]
        if not isinstance(new, dict):
            continue  # paper itself made a scalar or a list
        o, n = _flat(old), _flat(new)
        retyped = [p for p in n if p in o and type(n[p]) is not type(o[p])]
        assert retyped or set(n) != set(o), case.name


_LONG = re.compile(r'((?:"?(?:k\d{5}|a)"?\.){3})(?:"?(?:k\d{5}|a)"?\.)+("?(?:k\d{5}|a)"?)')


def test_long_dotted_key_texts(bases: list[Base], cases: dict[str, list[Case]]) -> None:
    """Each case holds a key of >= 500 parts, is under 300 KB, and is valid TOML once
    the long key is cut to a few parts (parsing the long key itself costs GBs)."""
    for case in cases["long-dotted-key"]:
        text = case.data.decode()
        parts = max(ln.count(".") + 1 for ln in text.splitlines())
        assert parts >= 500 and len(text) < 300_000, case.name
        doc = tomllib.loads(_LONG.sub(r"\1\2", text))
        base = _base(bases, case)
        assert all(doc[k] == v for k, v in base.doc.items() if k != "paper"), case.name
    for style in STYLES:  # and a short one of each style parses to the intended depth
        doc = tomllib.loads(dotted_key_text(40, style))
        node: Any = doc["fuzz_inline"] if style == "inline table" else doc
        depth = 0
        while isinstance(node, dict | list) and node:
            node = node[0] if isinstance(node, list) else next(iter(node.values()))
            depth += isinstance(node, dict)
        assert depth >= 39, style


def test_log_huge_int_ids(monkeypatch: pytest.MonkeyPatch) -> None:
    lines = load_log_lines(n=120)
    got = log_cases(30, 3, lines, ["log-huge-int"])
    assert got == log_cases(30, 3, lines, ["log-huge-int"])
    monkeypatch.setattr(sys, "get_int_max_str_digits", sys.get_int_max_str_digits)
    sys.set_int_max_str_digits(0)
    try:
        for case in got:
            new = case.data.decode().splitlines()
            assert len(new) == len(lines)
            diffs = [(a.split(), b.split()) for a, b in zip(lines, new) if a != b]
            assert diffs, case.name
            for old, tok in diffs:
                moved = [j for j in range(len(old)) if old[j] != tok[j]]
                assert moved and set(moved) <= {1, 2}, case.name
                for j in moved:
                    digits = tok[j].lstrip("+-")
                    assert len(digits) >= 4300 or abs(int(tok[j])) > 2**56 - 1, case.name
    finally:
        sys.set_int_max_str_digits(4300)


# --------------------------------------------------------------------------- classifier

def _summary(tmp_path: Path, data: dict) -> Path:
    path = tmp_path / "summary.json"
    path.write_text(json.dumps({"filters": {"srckf": {"runs_scored": 1, "rmse_m": 0.5}},
                                **data}))
    return path


def test_warning_printed_class(tmp_path: Path) -> None:
    warn = ("/x/numpy/_core/_methods.py:142: RuntimeWarning: invalid value encountered in "
            "scalar divide\n  ret = ret.dtype.type(ret / rcount)\n")
    v = assess(0, warn, [], _summary(tmp_path, {}), [])
    assert v.klass == "warning-printed" and "RuntimeWarning" in v.detail
    assert v.klass not in GOOD and "warning-printed" in v.flags
    assert assess(0, "", [], _summary(tmp_path, {}), []).klass == "ok"
    stated = "warning: the drag calibration missed its range target by 3 %\n"
    assert assess(0, stated, [], _summary(tmp_path, {}), []).klass == "ok"  # a stated one


def test_unexplained_null_class(tmp_path: Path) -> None:
    bare = {"turns": {"roll": {"rms": None, "max": None}}}
    v = assess(0, "", [], _summary(tmp_path, bare), [])
    assert v.klass == "unexplained-null" and v.nulls == ("turns.roll.rms", "turns.roll.max")
    explained = [
        {"turns": {"epochs": 0, "roll": {"rms": None}}},  # a zero count around it
        {"turns": {"rms": None, "rms_reason": "no epoch in a turn"}},
        # slam.nulls's count keys: a ship filter that never converged in any run
        {"converge_yaw_s": {"median": None, "never": 1, "converged_runs": 0}},
        {"gammas_rad": [0.2, None], "gammas_rad_reason": "inf: the Kalman filter"},
        {"limits": {"azimuth_limit_deg": None, "azimuth_observable": False}},
        {"provenance": {"scheduler": None}, "paper": {"x": None}},  # not scores
    ]
    for data in explained:
        assert assess(0, "", [], _summary(tmp_path, data), []).klass == "ok", data
    assert unexplained_nulls({"turns": {"epochs": 3, "rms": None}}) == ["turns.rms"]
    assert unexplained_nulls({"a": {"diverged_runs": 0, "rms": None}}) == ["a.rms"]
    assert null_pattern("reference.gtsam.cells[3].x") == "reference.*.cells[*].x"


def test_exact_dead_reckoning_baseline_is_not_degenerate(tmp_path: Path) -> None:
    """Noise-free readings (every σ 1e-160) make the odometry baseline exact: a score."""
    zero = {"runs_scored": 1, "pos_rmse_m": 0.0, "pos_err_range_m": {"x": [0.0, 0.0]}}
    exact = _summary(tmp_path, {"baselines": {"odometry": zero}})
    assert assess(0, "", [], exact, []).klass == "ok"
    path = tmp_path / "summary.json"
    path.write_text(json.dumps({"filters": {"srckf": zero}}))
    assert assess(0, "", [], path, []).klass == "degenerate-success"


def test_costly_rejection_and_usage_in_details(tmp_path: Path) -> None:
    one = "error: case.toml: the key has 30000 parts\n"
    missing = tmp_path / "none.json"
    cheap, dear = Usage(0.8, 90.0), Usage(8.5, 2400.0)
    assert assess(2, one, [], missing, ["case.toml"], cheap).klass == "rejected"
    v = assess(2, one, [], missing, ["case.toml"], dear, Limits())
    assert v.klass == "costly-rejection" and "cpu 8.5 s" in v.detail
    hang = assess(None, "", [], missing, [], Usage(59.0, 3100.0))
    assert hang.klass == "hang" and "peak 3.0 GiB" in hang.detail
    slow = assess(0, "", [], _summary(tmp_path, {}), [], Usage(40.0, 100.0), Limits(60.0),
                  seconds=45.0)
    assert slow.klass == "ok" and slow.flags == ("near-limit",)


def test_execute_usage_measures_memory_and_time(tmp_path: Path) -> None:
    alloc = [sys.executable, "-c", "b = bytearray(200 << 20); b[::4096] = b'x' * len(b[::4096])"]
    rc, _, _, used = execute_usage(alloc, tmp_path, Limits(seconds=20.0))
    assert rc == 0 and used.peak_mib >= 200
    sleep = [sys.executable, "-c", "import time; time.sleep(30)"]
    rc, seconds, _, used = execute_usage(sleep, tmp_path, Limits(seconds=0.5))
    assert rc is None and seconds < 5 and used.cpu_s < 5
