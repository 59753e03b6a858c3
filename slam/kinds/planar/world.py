"""The ``planar-slam`` world: a car-like vehicle driving a waypoint loop among point landmarks.

File layout (degrees only in the file, with ``_deg`` in the key; radians in the dataclasses)::

    kind = "planar-slam"
    description = "one line"
    runs = 50                  # Monte Carlo runs
    seed = 0                   # optional
    [map]      bounds_m = [xmin, xmax, ymin, ymax]; landmarks = [[x, y], ...];
               waypoints = [[x, y], ...]; or file = "data/x.json" ({"lm": [xs, ys], "wp": ...})
    [vehicle]  speed_mps, max_steer_deg, steer_rate_deg_s, wheelbase_m, dt_s, at_waypoint_m,
               loops, start_xy_m, start_heading_deg (default: towards the first waypoint),
               initial_sigma_xy_m, initial_sigma_heading_deg (default 0: start known exactly)
    [sensor]   max_range_m, period_steps, sigma_range_m, sigma_bearing_deg, front_half_plane
    [noise]    sigma_speed_mps, sigma_steer_deg
    [filters]  names (also the variants srckf-inv, ekf-fej, ...: slam/kinds/planar/variants.py),
               association ("known" | "nn"), gate_accept, gate_new,
               mode ("joint": sigma points over the whole state | "local": over the blocks
               a step touches, for ekf, srckf, srukf, srcdkf; see estimators/partitioned.py;
               the variants are joint only),
               online (true: also score iSAM2's current pose after every epoch, row
               "isam2"), fixed_lags_s ([s, ...] in [0, 1e6]: a fixed-lag smoother per lag,
               rows "fls-<lag>s"); both off by default (slam/kinds/planar/online.py)
    [paper]    free-form: the paper's reported numbers, passed through to summary.json

Keys of ``[vehicle]``, ``[sensor]``, ``[noise]`` and ``[filters]`` other than the start,
the filter names and the map default to Tim Bailey's simulator settings.
"""

from __future__ import annotations

import json
import math
import operator
from collections.abc import Iterator
from dataclasses import dataclass, replace
from importlib.resources.abc import Traversable
from typing import Any

import numpy as np
from numpy.typing import NDArray

import worlds.common as wc
import worlds.schema as ws
from estimators import wrap_angle
from estimators.filters import FILTER_NAMES  # the one list of filter names
from slam.kinds.planar.variants import PLANAR_FILTERS, PLANAR_LOCAL_FILTERS
from worlds import limits

Array = NDArray[np.float64]
DEG = math.pi / 180.0
KIND = "planar-slam"
ASSOCIATIONS = ("known", "nn")
MODES = ("joint", "local")
LOCAL_FILTERS = PLANAR_LOCAL_FILTERS

COORD = ws.Interval(-1e6, 1e6)
"""Allowed map coordinates (m)."""


def _frozen(a: Any) -> Array:
    out = np.array(a, dtype=float)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class MapSpec:
    """Map: ``bounds_m = (xmin, xmax, ymin, ymax)``, landmarks ``(N, 2)``, waypoints ``(M, 2)``.

    The arrays are read-only.
    """

    bounds_m: tuple[float, float, float, float]
    landmarks: Array
    waypoints: Array

    def __post_init__(self) -> None:
        object.__setattr__(self, "landmarks", _frozen(self.landmarks).reshape(-1, 2))
        object.__setattr__(self, "waypoints", _frozen(self.waypoints).reshape(-1, 2))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, MapSpec):
            return NotImplemented
        return (
            self.bounds_m == other.bounds_m
            and np.array_equal(self.landmarks, other.landmarks)
            and np.array_equal(self.waypoints, other.waypoints)
        )

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True)
class VehicleSpec:
    """Car-like vehicle and its waypoint-following controller (angles in radians)."""

    speed_mps: float = 3.0
    max_steer_rad: float = 30.0 * DEG
    steer_rate_rad_s: float = 20.0 * DEG
    wheelbase_m: float = 4.0
    dt_s: float = 0.025
    at_waypoint_m: float = 1.0
    loops: int = 2
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Start pose ``(x m, y m, heading rad)``: the filters' ``x0``."""
    initial_pose_sigma: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Std of the true start about ``start`` ``(m, m, rad)``: the filters' ``P0``."""


@dataclass(frozen=True)
class RangeBearingSpec:
    """Range-bearing sensor, sampled every ``period_steps`` control steps."""

    max_range_m: float = 30.0
    period_steps: int = 8
    sigma_range_m: float = 0.1
    sigma_bearing_rad: float = 1.0 * DEG
    front_half_plane: bool = True


@dataclass(frozen=True)
class ControlNoise:
    """Std of the noise on the controls the filters see."""

    sigma_speed_mps: float = 0.3
    sigma_steer_rad: float = 3.0 * DEG


@dataclass(frozen=True)
class FilterSpec(wc.TunedFilters):
    """Which filters to run, their settings tables, and how they associate data."""

    names: tuple[str, ...] = ("ekf", "srckf", "srukf", "srcdkf")
    association: str = "known"
    gate_accept: float = 4.0
    gate_new: float = 25.0
    mode: str = "joint"


@dataclass(frozen=True)
class PlanarFilterSpec(FilterSpec):
    """:class:`FilterSpec` and the planar kind's online rows: ``online`` adds iSAM2's
    current pose after every epoch (row ``isam2``), ``fixed_lags_s`` a fixed-lag smoother
    per lag (rows ``fls-<lag>s``; :mod:`slam.kinds.planar.online`)."""

    online: bool = False
    fixed_lags_s: tuple[float, ...] = ()


MAX_LAG_S = 1e6
"""Longest fixed lag (s)."""


class Lags(ws.NumberList):
    """A list of up to ``max_len`` numbers in ``interval``; empty is allowed (no rows)."""

    def parse(self, value: Any, where: ws.Where) -> tuple[float, ...]:
        return () if value == [] else super().parse(value, where)


@dataclass(frozen=True)
class World(wc.WorldBase):
    """A validated planar world."""

    map: MapSpec
    vehicle: VehicleSpec
    sensor: RangeBearingSpec
    noise: ControlNoise
    filters: PlanarFilterSpec


def filters_section(modes: tuple[str, ...], into: type, *, gate_accept: float,
                    gate_new: float, names: tuple[str, ...] = FILTER_NAMES,
                    **extra: ws.Field) -> ws.Section:
    """The ``[filters]`` table of a SLAM world: filter names (from ``names``), association,
    the nearest-neighbour gates (squared Mahalanobis), the mode, and kind-specific keys."""
    return ws.Section(
        {
            "names": ws.StringList(names),
            "association": ws.String(choices=ASSOCIATIONS, default="known"),
            "gate_accept": ws.Number(ws.positive(1_000.0), default=gate_accept),
            "gate_new": ws.Number(ws.positive(10_000.0), default=gate_new),
            "mode": ws.String(choices=modes, default="joint"),
            **wc.settings_tables(),
            **extra,
        },
        into=into,
    )


GATES = ws.Rule("filters.gate_new", "filters.gate_accept", operator.ge,
                "must be >= {other} ({limit:g})")
"""A new landmark's gate is not inside the accepting one."""

WORLD = wc.world(KIND, World, {
    "map": ws.Section(
        {
            "bounds_m": ws.Vector(4, COORD),
            "file": ws.String(default=None),
            "landmarks": ws.Points(default=None),
            "waypoints": ws.Points(default=None),
        }
    ),
    "vehicle": ws.Section(
        {
            "speed_mps": ws.Number(ws.positive(50.0), default=3.0),
            "max_steer_deg": ws.Number(ws.Interval(0.0, 90.0, True, True), 30.0, DEG)
            .to("max_steer_rad"),
            "steer_rate_deg_s": ws.Number(ws.positive(360.0), 20.0, DEG).to("steer_rate_rad_s"),
            "wheelbase_m": ws.Number(ws.positive(20.0), default=4.0),
            "dt_s": ws.Number(ws.positive(1.0), default=0.025),
            "at_waypoint_m": ws.Number(ws.positive(100.0), default=1.0),
            "loops": ws.Integer(ws.Interval(1, 100), default=2),
            "start_xy_m": ws.Vector(2, COORD).to(None),
            "start_heading_deg": ws.Number(ws.Interval(-360.0, 360.0), None, DEG).to(None),
            "initial_sigma_xy_m": ws.Sigma(ws.Interval(0.0, 100.0), 0.0).to(None),
            "initial_sigma_heading_deg": ws.Sigma(ws.Interval(0.0, 180.0), 0.0, DEG).to(None),
        },
        into=VehicleSpec,
    ),
    "sensor": ws.Section(
        {
            "max_range_m": ws.Number(ws.positive(10_000.0), default=30.0),
            "period_steps": ws.Integer(ws.Interval(1, 100_000), default=8),
            "sigma_range_m": ws.Sigma(ws.positive(100.0), default=0.1),
            "sigma_bearing_deg": ws.Sigma(ws.positive(45.0), 1.0, DEG).to("sigma_bearing_rad"),
            "front_half_plane": ws.Boolean(default=True),
        },
        required=False,
        into=RangeBearingSpec,
    ),
    "noise": ws.Section(
        {
            "sigma_speed_mps": ws.Sigma(ws.positive(10.0), default=0.3),
            "sigma_steer_deg": ws.Sigma(ws.positive(45.0), 3.0, DEG).to("sigma_steer_rad"),
        },
        required=False,
        into=ControlNoise,
    ),
    "filters": filters_section(MODES, PlanarFilterSpec, gate_accept=4.0, gate_new=25.0,
                               names=PLANAR_FILTERS, online=ws.Boolean(default=False),
                               fixed_lags_s=Lags(ws.Interval(0.0, MAX_LAG_S), max_len=20,
                                                 default=[])),
}, paper=wc.PAPER_RANGES)
SCHEMA = WORLD.schema


def _read_map_file(rel: str, base: Traversable | None, where: ws.Where) -> dict[str, Array]:
    """Read ``{"lm": [xs, ys], "wp": [xs, ys]}`` (either may be absent) next to the world."""
    if base is None:
        raise where.error("a map file needs a world file to be relative to", rel)
    target = base.joinpath(rel)
    limits.check_file(target, lambda why: where.error(why, rel))
    try:
        data = json.loads(target.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise where.error("file not found", rel) from None
    except (OSError, ValueError) as exc:
        raise where.error(f"cannot read as JSON: {exc}", rel) from None
    except RecursionError:
        raise where.error("cannot read as JSON: nested too deeply", rel) from None
    if not isinstance(data, dict) or not set(data) <= {"lm", "wp"}:
        raise where.error('must hold a JSON object with keys "lm" and/or "wp"', rel)
    out = {}
    for key, rows in data.items():
        ok = (
            isinstance(rows, list)
            and len(rows) == 2
            and all(isinstance(r, list) for r in rows)
            and len(rows[0]) == len(rows[1])
            and all(_finite_number(v) for r in rows for v in r)
        )
        if not ok:
            raise where.error(f'"{key}" must be [[x...], [y...]] of finite numbers', rel)
        out[key] = np.array(rows, dtype=float).T.reshape(-1, 2)
    return out


def _finite_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _inside(points: Array, bounds: tuple[float, ...]) -> NDArray[np.bool_]:
    xmin, xmax, ymin, ymax = bounds
    return (
        (points[:, 0] >= xmin)
        & (points[:, 0] <= xmax)
        & (points[:, 1] >= ymin)
        & (points[:, 1] <= ymax)
    )


def outside_rule(bounds: tuple[float, ...]) -> str:
    """The error message of a point outside the map."""
    return f"outside the map bounds_m {list(bounds)}"


def first_outside(points: Array, bounds: tuple[float, ...]) -> int | None:
    """Index of the first point outside ``bounds`` (or None)."""
    outside = np.flatnonzero(~_inside(points, bounds))
    return int(outside[0]) if outside.size else None


def check_inside(points: Array, bounds: tuple[float, ...], at: ws.Where) -> None:
    """Refuse the first of the inline ``points`` (at ``at[i]``) outside ``bounds``."""
    i = first_outside(points, bounds)
    if i is not None:
        raise at.item(i).error(outside_rule(bounds), points[i].tolist())


def check_bounds(bounds: tuple[float, ...], at: ws.Where) -> None:
    """``bounds_m`` is ``[xmin, xmax, ymin, ymax]`` with each min below its max."""
    if not (bounds[0] < bounds[1] and bounds[2] < bounds[3]):
        raise at.error("must be [xmin, xmax, ymin, ymax] with min < max", list(bounds))


def start_pose(vehicle: dict[str, Any], bounds: tuple[float, ...], waypoints: Array,
               at: ws.Where) -> tuple[float, float, float]:
    """``(x, y, heading)`` of the start; by default heading towards the first waypoint."""
    sx, sy = vehicle["start_xy_m"]
    if not _inside(np.array([[sx, sy]]), bounds)[0]:
        raise at.child("start_xy_m").error(outside_rule(bounds), [sx, sy])
    heading = vehicle["start_heading_deg"]
    if heading is None:  # towards the first waypoint
        wx, wy = waypoints[0]
        heading = math.atan2(wy - sy, wx - sx) if (wx, wy) != (sx, sy) else 0.0
    return sx, sy, wrap_angle(float(heading))


def _map_points(m: dict[str, Any], base: Traversable | None, at_map: ws.Where
                ) -> dict[str, Array]:
    """Landmarks and waypoints, each inline or from the map file, inside the bounds."""
    bounds = m["bounds_m"]
    from_file = _read_map_file(m["file"], base, at_map.child("file")) if m["file"] else {}
    points = {}
    for key, short in (("landmarks", "lm"), ("waypoints", "wp")):
        at, inline = at_map.child(key), m[key]
        if inline is not None and short in from_file:
            raise at.error(f"given both inline and in map file {m['file']!r}")
        if inline is None and short not in from_file:
            raise at.error("missing (required, inline or via [map] file)")
        if inline is not None:
            check_inside(inline, bounds, at)
        elif (i := first_outside(from_file[short], bounds)) is not None:
            pt = from_file[short][i].tolist()
            raise at_map.child("file").error(f"{key}[{i}] = {pt} is {outside_rule(bounds)}",
                                             m["file"])
        points[key] = inline if inline is not None else from_file[short]
    if len(points["waypoints"]) < 2:
        raise at_map.child("waypoints").error(
            "needs at least 2 waypoints", points["waypoints"].tolist()
        )
    if len(points["landmarks"]) < 1:
        raise at_map.child("landmarks").error("needs at least 1 landmark", [])
    return points


def check_local_mode(fil: dict[str, Any], at: ws.Where,
                     local: tuple[str, ...] = LOCAL_FILTERS) -> None:
    """``mode = "local"`` only with filters that have a local mode (``local``)."""
    no_local = [n for n in fil["names"] if n not in local]
    if fil["mode"] == "local" and no_local:
        rule = (f"local mode supports {', '.join(local)} only, not "
                f"{', '.join(no_local)} (use mode = \"joint\")")
        raise at.error(rule, fil["mode"])


def check_lags(lags: tuple[float, ...], at: ws.Where) -> None:
    """Fixed lags name distinct rows (``fls-<lag>s``): no two may print alike."""
    names = [f"{lag:g}" for lag in lags]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise at.item(i).error(f"repeats lag {n} s", lags[i])


ONLINE = "isam2"
"""Name of the online-optimum row (:mod:`slam.kinds.planar.online`)."""


def fixed_lag_name(lag_s: float) -> str:
    """The row name of a fixed-lag smoother: ``fls-2s``, ``fls-0.5s``."""
    return f"fls-{lag_s:g}s"


def online_rows(fs: Any) -> list[str]:
    """The online rows a ``[filters]`` section asks for (``isam2``, ``fls-<lag>s``; none for
    a kind without them)."""
    lags = [fixed_lag_name(lag) for lag in getattr(fs, "fixed_lags_s", ())]
    return ([ONLINE] if getattr(fs, "online", False) else []) + lags


def with_online(w: Any, online: bool, fixed_lags: tuple[float, ...]) -> Any:
    """``--online`` / ``--fixed-lag S``: world ``w`` with those rows added; ``ValueError``
    (the one-line message) for a kind without online rows or a lag outside [0, 1e6] s."""
    if not online and not fixed_lags:
        return w
    if not hasattr(w.filters, "online"):
        opt = "--online" if online else "--fixed-lag"
        raise ValueError(f"{opt}: world {w.name} (kind {w.kind}) has no online rows "
                         "(planar-slam and drone-slam worlds, recorded planar logs)")
    if fixed_lags and not hasattr(w.filters, "fixed_lags_s"):
        raise ValueError(f"--fixed-lag: world {w.name} (kind {w.kind}) has no fixed-lag "
                         "rows (planar-slam worlds only)")
    if not fixed_lags:
        return replace(w, filters=replace(w.filters, online=True))
    lags = list(w.filters.fixed_lags_s)
    for lag in fixed_lags:
        if not (math.isfinite(lag) and 0.0 <= lag <= MAX_LAG_S):
            raise ValueError(f"--fixed-lag {lag:g}: must be in [0, 1e6] seconds")
        if f"{lag:g}" not in {f"{x:g}" for x in lags}:
            lags.append(float(lag))
    return replace(w, filters=replace(w.filters, online=w.filters.online or online,
                                      fixed_lags_s=tuple(lags)))


def _steps(length: float, speed: float, dt: float) -> float:
    """Control steps to drive ``length`` metres (``inf`` when it overflows)."""
    try:
        return length / (speed * dt) if speed * dt > 0.0 else math.inf
    except OverflowError:
        return math.inf


def work(w: World) -> Iterator[limits.Size]:
    """What one run costs (:mod:`worlds.limits`): control steps, filter epochs, the state
    if every landmark near the path is mapped, the filter work - in that order (the
    landmarks near the path are counted only for a path of allowed length)."""
    veh, sen, lms, wps = w.vehicle, w.sensor, w.map.landmarks, w.map.waypoints
    length = limits.path_length(veh.start[:2], wps, veh.loops)
    steps = _steps(length, veh.speed_mps, veh.dt_s)
    yield limits.Size("samples", "control steps", steps, "vehicle.speed_mps",
                      f"a {length:.4g} m path at speed_mps = {veh.speed_mps:g} with "
                      f"dt_s = {veh.dt_s:g}")
    epochs = steps / sen.period_steps + 1
    yield limits.Size("epochs", "filter epochs", epochs, "sensor.period_steps")
    turn = veh.wheelbase_m / math.tan(veh.max_steer_rad)
    near = limits.near_path(lms, veh.start[:2], wps, sen.max_range_m + veh.at_waypoint_m
                            + 2.0 * turn)
    state = 3 + 2 * near
    yield limits.Size("state", "state dimensions", state, "map.landmarks",
                      f"{near} landmarks within sensor range of the path")
    width = 2 * sen.period_steps  # the control-noise inputs of one prediction
    joint = w.filters.mode == "joint"
    cost = epochs * ((state + width) ** 3 if joint else (3 + width) ** 3 + 10 * state**2)
    yield limits.Size("work", "units of filter work", cost,
                      "filters.mode" if joint else "sensor.period_steps",
                      f"{limits.count(epochs)} epochs, state {state}, {width} noise inputs "
                      f"per prediction, {w.filters.mode} mode")


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None) -> World:
    """Validate a parsed ``planar-slam`` TOML document and build its :class:`World`.

    ``source`` is the file name shown in errors; ``base`` the folder map files are read from.
    """
    root = ws.Where(source, "")
    v = ws.read_table(data, SCHEMA, root)
    m, veh = v["map"], v["vehicle"]
    check_bounds(m["bounds_m"], root.child("map.bounds_m"))
    points = _map_points(m, base, root.child("map"))
    start = start_pose(veh, m["bounds_m"], points["waypoints"], root.child("vehicle"))
    check_local_mode(v["filters"], root.child("filters.mode"))
    check_lags(v["filters"]["fixed_lags_s"], root.child("filters.fixed_lags_s"))
    wc.check_settings(v["filters"], v["filters"]["names"], root.child("filters"))
    ws.check_rules((GATES,), v, root)
    sigma = (veh["initial_sigma_xy_m"], veh["initial_sigma_xy_m"],
             veh["initial_sigma_heading_deg"])
    world = ws.build(
        WORLD, v, name=name, source=source,
        map=MapSpec(m["bounds_m"], points["landmarks"], points["waypoints"]),
        vehicle=ws.build(SCHEMA["vehicle"], veh, start=start, initial_pose_sigma=sigma),
    )
    return world
