"""Every filter name the command line accepts runs on every bundled world whose models
it supports: one short run each (the world cut to its first waypoints, one loop, or a
few seconds), all filters on the same log, no divergence.  The dense filters (ckf, ukf,
cdkf, hommukf) start from the worlds' zero initial vehicle covariance."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from estimators import FILTER_NAMES
from slam.registry import get_kind, load_world
from worlds import WorldError, bundled_names

KINDS = ("planar-slam", "drone-slam", "attitude")


def _short(w):
    """The world cut to one short run of its own models and map: 5 s of an attitude
    world; 15 m straight ahead from a SLAM world's start, one loop."""
    if w.kind == "attitude":
        return replace(w, duration_s=5.0, scoring=replace(w.scoring, steady_state_from_s=2.0))
    veh = w.vehicle
    if hasattr(veh, "start"):
        x, y, heading = veh.start
    else:
        (x, y), heading = veh.start_xy, veh.start_heading_rad
    ahead = np.array([[x + d * np.cos(heading), y + d * np.sin(heading)] for d in (7.5, 15.0)])
    return replace(w, map=replace(w.map, waypoints=ahead), vehicle=replace(veh, loops=1))


def _bundled() -> list[str]:
    names = []
    for name in bundled_names():
        try:
            w = load_world(name)
        except WorldError:  # a world of a kind not registered (yet)
            continue
        if w.kind in KINDS:
            names.append(name)
    return names


@pytest.mark.parametrize("name", _bundled())
def test_every_filter_runs_on_the_bundled_world(name):
    w = _short(load_world(name))
    filters = list(FILTER_NAMES)
    if getattr(w.filters, "mode", "joint") == "local":
        w = replace(w, filters=replace(w.filters, mode="joint"))
    out = get_kind(w.kind).run_once(w, 0, np.random.SeedSequence(1), filters, reference=False)
    failed = {n: s.failure for n, s in out.scores.items() if s.diverged}
    assert not failed, failed
    assert set(filters) <= set(out.scores)
