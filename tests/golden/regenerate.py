"""Regenerate the golden campaign summaries in ``tests/golden/`` - deliberately.

Each ``<name>.summary.json`` here is the ``summary.json`` of one small fixed-seed campaign
(:data:`CAMPAIGNS`), run in-process (``workers=1``) with the code as it was when the file
was written, with every key containing ``time`` removed (wall-clock timings differ from
run to run).  ``tests/slam/test_golden.py`` re-runs the same campaigns and compares.

Usage, from the repository root::

    .venv/bin/python -m tests.golden.regenerate              # rewrite every file
    .venv/bin/python -m tests.golden.regenerate star-sensor  # rewrite some
    .venv/bin/python -m tests.golden.regenerate --check      # compare only, write nothing

Comparison (:func:`golden_differences`, used by the test and by ``--check``): the same keys
in the same order, the same list lengths, ints, strings, booleans and nulls exactly equal,
floats equal to :data:`REL_TOL` = 1e-9 relative - different BLAS/LAPACK builds (or GTSAM
wheels, or numpy's loops for another CPU) may round the last bits differently, and a
campaign amplifies those a little - with an absolute floor of :data:`ABS_TOL` = 1e-12 for
values that are rounding noise around zero (e.g. the smoother's 3.5e-18 m error at the
known start).  Two parts are compared on their own scale (:func:`batched_differences`):
the ranking's paired differences and the paper's orderings, differences of two filters'
MSEs that may be equal to round-off (star-sensor's SRCKF and CKF to 1e-11: on another CPU
their difference changes sign), to 1e-9 of the MSEs they are differences of; and the GTSAM
smoother's rows (every key under a ``reference``), to :data:`REFERENCE_REL_TOL` = 1e-6: the
smoother's estimate is defined to its Levenberg-Marquardt stopping tolerance, not to
round-off, and the last bits move where it stops along the optimum's flattest directions
(measured: the drone smoother's rows 2.6e-8 relative apart on an AVX-512 machine and on the
machine that wrote the files).

When to regenerate: only when a change is *meant* to change the numbers (a new model, a
fixed bug, a new summary key).  Run this, read ``git diff tests/golden`` to see that the
numbers moved the way the change says they should, and commit the files together with the
change.  A refactoring meant to keep behaviour must pass ``test_golden.py`` without it.

The campaigns (``runs`` and ``seed`` fixed here, never the world's defaults):

* ``bailey-joint``, ``bailey-local`` - the bundled ``bailey`` world driven one lap of its
  loop instead of two (half the time; the lap closes the loop), 1 run, seed 0, in joint
  and in local mode (as ``slam run bailey --runs 1 --seed 0 [--mode local]`` would on a
  one-lap copy of ``bailey.toml``);
* ``star-sensor`` - the bundled ``star-sensor`` world cut to 120 s (steady state from
  60 s), 2 runs, seed 0;
* ``drone`` - ``small-drone.toml`` here (a 30 m loop over a hill), 1 run, seed 0;
* ``victoria-park-300`` - the first 300 lines of GTSAM's ``victoria_park.txt``
  (``gtsam.findExampleDataFile``), written to a scratch folder as
  ``victoria_park_300.txt`` and opened from there by its relative name, so the summary's
  ``log`` and ``source`` keys do not depend on the folder.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
VICTORIA_LINES = 300
VICTORIA_FILE = "victoria_park_300.txt"


@dataclass(frozen=True)
class Campaign:
    """One golden campaign: how to build its world, its runs and its seed."""

    name: str
    world: Callable[[], Any]
    runs: int
    seed: int

    @property
    def path(self) -> Path:
        return HERE / f"{self.name}.summary.json"


def _bailey(mode: str) -> Any:
    from slam.registry import load_world

    w = load_world("bailey")
    w = replace(w, vehicle=replace(w.vehicle, loops=1))
    return w if w.filters.mode == mode else replace(w, filters=replace(w.filters, mode=mode))


def _star_sensor() -> Any:
    from slam.registry import load_world

    w = load_world("star-sensor")
    return replace(w, duration_s=120.0, scoring=replace(w.scoring, steady_state_from_s=60.0))


def _drone() -> Any:
    from slam.registry import load_world

    return load_world(HERE / "small-drone.toml")


def victoria_prefix_text(lines: int = VICTORIA_LINES) -> str:
    """The first ``lines`` lines of GTSAM's bundled ``victoria_park.txt``."""
    import gtsam

    text = Path(gtsam.findExampleDataFile("victoria_park.txt")).read_text(encoding="utf-8")
    return "".join(text.splitlines(keepends=True)[:lines])


def _victoria() -> Any:
    """The log world; call with the scratch folder holding the prefix as the cwd."""
    from slam.registry import log_kind

    return log_kind().open_log(Path(VICTORIA_FILE), None, None)


CAMPAIGNS: dict[str, Campaign] = {c.name: c for c in (
    Campaign("bailey-joint", lambda: _bailey("joint"), runs=1, seed=0),
    Campaign("bailey-local", lambda: _bailey("local"), runs=1, seed=0),
    Campaign("star-sensor", _star_sensor, runs=2, seed=0),
    Campaign("drone", _drone, runs=1, seed=0),
    Campaign("victoria-park-300", _victoria, runs=1, seed=0),
)}


REL_TOL = 1e-9
ABS_TOL = 1e-12
REFERENCE_REL_TOL = 1e-6


def differences(golden: Any, new: Any, where: str = "summary", rel_tol: float = REL_TOL
                ) -> list[str]:
    """Where ``new`` differs from ``golden`` (empty if they agree; see the module notes),
    floats to ``rel_tol``."""
    if isinstance(golden, dict) and isinstance(new, dict):
        if list(golden) != list(new):
            return [f"{where}: keys {list(golden)} != {list(new)}"]
        return [d for k in golden
                for d in differences(golden[k], new[k], f"{where}.{k}", rel_tol)]
    if isinstance(golden, list) and isinstance(new, list):
        if len(golden) != len(new):
            return [f"{where}: length {len(golden)} != {len(new)}"]
        return [d for i, (g, n) in enumerate(zip(golden, new))
                for d in differences(g, n, f"{where}[{i}]", rel_tol)]
    if type(golden) is not type(new):
        return [f"{where}: {golden!r} ({type(golden).__name__}) != {new!r} "
                f"({type(new).__name__})"]
    if isinstance(golden, float):
        if math.isclose(golden, new, rel_tol=rel_tol, abs_tol=ABS_TOL):
            return []
        return [f"{where}: {golden!r} != {new!r} (relative difference "
                f"{abs(new - golden) / max(abs(golden), abs(new)):.1e})"]
    return [] if golden == new else [f"{where}: {golden!r} != {new!r}"]


DIFFERENCES = ("delta_mse", "delta_se", "delta_percent", "z")


def _split_reference(summary: Any) -> tuple[Any, dict[str, Any]]:
    """``summary`` without its smoother rows (every dict key ``reference``, at any depth),
    and those rows by their path."""
    found: dict[str, Any] = {}

    def walk(obj: Any, where: str) -> Any:
        if isinstance(obj, dict):
            out = {}
            for k, v in obj.items():
                if k == "reference":
                    found[f"{where}.{k}"] = v
                else:
                    out[k] = walk(v, f"{where}.{k}")
            return out
        return obj

    return walk(summary, "summary"), found


def golden_differences(golden: dict, new: dict) -> list[str]:
    """Where a re-run summary ``new`` differs from the stored ``golden`` (module notes): the
    smoother's rows to :data:`REFERENCE_REL_TOL`, the ranking's paired differences on their
    own scale (:func:`batched_differences`), everything else to :data:`REL_TOL`.  Neither
    argument is changed."""
    import copy

    rest_g, ref_g = _split_reference(copy.deepcopy(golden))
    rest_n, ref_n = _split_reference(copy.deepcopy(new))
    if list(ref_g) != list(ref_n):
        return [f"smoother rows at {list(ref_g)} != {list(ref_n)}"]
    out = batched_differences(rest_g, rest_n)
    for where, g in ref_g.items():
        out += differences(g, ref_n[where], where, REFERENCE_REL_TOL)
    return out


def batched_differences(per_run: dict, batched: dict) -> list[str]:
    """Where the batched path's summary differs from the per-run path's: every key to
    1e-9 relative (:func:`differences`), but the ranking's paired differences (differences
    of two filters' MSEs that may agree to 1e-4, so round-off of 1e-13 in each is 1e-9 of
    their difference) to 1e-9 of the MSEs they are differences of."""
    rank_a, rank_b = per_run.pop("ranking", {}), batched.pop("ranking", {})
    head_a, head_b = per_run.pop("headline", ""), batched.pop("headline", "")
    order_a, order_b = per_run.pop("paper_ordering", []), batched.pop("paper_ordering", [])
    out = differences(per_run, batched)
    for metric, block in rank_a.items():
        other = rank_b[metric]
        rows_a, rows_b = block.pop("rows", {}), other.pop("rows", {})
        out += differences(block, other, f"ranking.{metric}")
        for name, ra in rows_a.items():
            rb = dict(rows_b[name])
            scale = {"delta_mse": ra["mse"], "delta_se": ra["mse"], "delta_percent": 100.0,
                     "z": ra["mse"] / ra["delta_se"] if ra["delta_se"] else 0.0}
            for key in DIFFERENCES:
                a, b = ra.pop(key), rb.pop(key)
                if (a is None) != (b is None) or (a is not None
                                                  and abs(a - b) > 1e-9 * scale[key]):
                    out.append(f"ranking.{metric}.{name}.{key}: {a!r} != {b!r}")
            out += differences(ra, rb, f"ranking.{metric}.rows.{name}")
    for i, (oa, ob) in enumerate(zip(order_a, order_b)):
        scale = {"mean": oa.get("rmse_worse", 0.0) ** 2, "se": oa.get("rmse_worse", 0.0) ** 2}
        scale["z"] = scale["mean"] / oa["se"] if oa.get("se") else 0.0
        for key in ("mean", "se", "z"):
            a, b = oa.pop(key, None), ob.pop(key, None)
            if (a is None) != (b is None) or (a is not None and abs(a - b) > 1e-9 * scale[key]):
                out.append(f"paper_ordering[{i}].{key}: {a!r} != {b!r}")
        oa.pop("verdict", None), ob.pop("verdict", None)  # of differences of round-off
        oa.pop("a_better_runs", None), ob.pop("a_better_runs", None)
        out += differences(oa, ob, f"paper_ordering[{i}]")
    if head_a.split(" (")[0] != head_b.split(" (")[0]:  # the same best filter named first
        out.append(f"headline: {head_a[:60]!r} != {head_b[:60]!r}")
    return out


def strip_timings(obj: Any) -> Any:
    """``obj`` without any dict key containing ``time`` (at any depth) and without the
    ``provenance`` block (when, where and how the campaign ran: not a result)."""
    if isinstance(obj, dict):
        return {k: strip_timings(v) for k, v in obj.items()
                if "time" not in str(k) and k != "provenance"}
    if isinstance(obj, list | tuple):
        return [strip_timings(v) for v in obj]
    return obj


@contextlib.contextmanager
def _scratch_cwd():
    """A scratch folder holding the Victoria Park prefix, as the working directory."""
    with tempfile.TemporaryDirectory(prefix="golden-") as tmp:
        (Path(tmp) / VICTORIA_FILE).write_text(victoria_prefix_text(), encoding="utf-8")
        with contextlib.chdir(tmp):
            yield Path(tmp)


def run(campaign: Campaign) -> dict[str, Any]:
    """Run ``campaign`` in-process and return its summary as ``summary.json`` holds it
    (strict JSON: NaN as ``null``), timings stripped."""
    from slam.campaign import run_campaign
    from slam.render.tables import summary_json

    with _scratch_cwd():
        world = campaign.world()
        result = run_campaign(world, runs=campaign.runs, seed=campaign.seed, workers=1,
                              executor="per-run")
    return json.loads(summary_json(strip_timings(result.summary)))


def golden_text(summary: dict[str, Any]) -> str:
    """The file text of a golden summary (the renderer's strict JSON)."""
    from slam.render.tables import summary_json

    return summary_json(summary)


def load(campaign: Campaign) -> dict[str, Any]:
    """The stored golden summary of ``campaign``."""
    return json.loads(campaign.path.read_text(encoding="utf-8"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m tests.golden.regenerate",
        description="Regenerate the golden campaign summaries in tests/golden/.")
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help=f"campaigns to regenerate (default: all): {', '.join(CAMPAIGNS)}")
    parser.add_argument("--check", action="store_true",
                        help="only compare with the stored files (as the test does); "
                             "write nothing; exit 1 if any differs")
    args = parser.parse_args(argv)
    unknown = [n for n in args.names if n not in CAMPAIGNS]
    if unknown:
        parser.error(f"unknown campaign {', '.join(unknown)}; known: {', '.join(CAMPAIGNS)}")
    changed = 0
    for name in args.names or list(CAMPAIGNS):
        c = CAMPAIGNS[name]
        new = run(c)
        text = golden_text(new)
        old = c.path.read_text(encoding="utf-8") if c.path.exists() else None
        if old == text:
            print(f"{c.path.name}: unchanged")
            continue
        if args.check:
            diff = golden_differences(json.loads(old), new) if old is not None else ["missing"]
            changed += bool(diff)
            print(f"{c.path.name}: " + ("; ".join(diff[:5]) if diff else
                                        "agrees within the tolerances (not bit-identical)"))
        else:
            changed += 1
            c.path.write_text(text, encoding="utf-8")
            print(f"{c.path.name}: {'written' if old is None else 'rewritten'}")
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
