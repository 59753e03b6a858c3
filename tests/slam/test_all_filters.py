"""Every filter name the command line accepts for a kind (:attr:`slam.kind.Kind.filters`)
runs on every bundled world of that kind: one short run each (the world cut to its first
waypoints, one loop, or a few seconds), all filters on the same log, no divergence.  The
dense filters (ckf, ukf, cdkf, hommukf) start from the SLAM worlds' zero initial vehicle
covariance.  A bundled world of a kind with no shortener here fails: a new kind adds one."""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from slam.registry import get_kind, load_world, world_from_dict
from worlds import bundled_names
from worlds.loader import read_world


def _slam_world(w):
    """15 m straight ahead from a SLAM world's start, one loop, joint mode."""
    veh = w.vehicle
    if hasattr(veh, "start"):
        x, y, heading = veh.start
    else:
        (x, y), heading = veh.start_xy, veh.start_heading_rad
    ahead = np.array([[x + d * np.cos(heading), y + d * np.sin(heading)] for d in (7.5, 15.0)])
    w = replace(w, map=replace(w.map, waypoints=ahead), vehicle=replace(veh, loops=1))
    if getattr(w.filters, "mode", "joint") == "local":
        w = replace(w, filters=replace(w.filters, mode="joint"))
    return w


def _attitude(w):
    return replace(w, duration_s=5.0, scoring=replace(w.scoring, steady_state_from_s=2.0))


def _overridden(name: str, overrides: dict[str, Any]):
    """The bundled document ``name`` with dotted-key overrides, validated again."""
    data = copy.deepcopy(read_world(name).data)
    for dotted, value in overrides.items():
        *path, key = dotted.split(".")
        table = data
        for part in path:
            table = table.setdefault(part, {})
        table[key] = value
    return world_from_dict(data, name=f"short-{name}")


SHORT: dict[str, Callable[[str], Any]] = {
    "planar-slam": lambda name: _slam_world(load_world(name)),
    "drone-slam": lambda name: _slam_world(load_world(name)),
    "attitude": lambda name: _attitude(load_world(name)),
    "ship": lambda name: _overridden(name, {  # 20 s from a 45° yaw error: not yet within 10°
        "duration_s": 20.0, "scoring.steady_state_from_s": 10.0, "scoring.divergence_deg": 45.0}),
    "spinning": lambda name: _overridden(name, {
        "sample_interval_s": 1.0, "sweep.factors": [2.0], "sweep.gammas_rad": [2.0],
        "sweep.runs_per_cell": 1, "sweep.filters": ["srckf"]}),
    "fixed-wing": lambda name: _overridden(name, {
        "duration_s": 20.0, "flight.manoeuvre_start_s": [2.0], "flight.manoeuvre_ramp_s": [4.0],
        "flight.turn_rate_deg_s": [9.0], "flight.climb_deg": [0.0], "flight.speed_mps": [25.0]}),
    "alignment": lambda name: _overridden(name, {"duration_s": 2.0, "scoring.settled_from_s": 1.0,
                                                 "sweep.runs": 0}),
}
"""Kind -> the bundled world ``name`` cut to one short run of its own models."""


@pytest.mark.parametrize("name", bundled_names())
def test_every_filter_the_kind_accepts_runs_on_the_bundled_world(name):
    kind = load_world(name).kind
    assert kind in SHORT, f"no short version of kind {kind} here: add one to SHORT"
    w = SHORT[kind](name)
    filters = list(get_kind(kind).filters)
    out = get_kind(kind).run_once(w, 0, np.random.SeedSequence(1), filters, reference=False)
    failed = {n: s.failure for n, s in out.scores.items() if s.diverged}
    assert not failed, failed
    assert set(filters) <= set(out.scores)
