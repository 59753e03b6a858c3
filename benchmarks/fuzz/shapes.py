"""Structural world mutators: degenerate geometry, huge derived sizes, hostile files,
binary junk, deep nesting, TOML syntax errors and odd strings.

Each family is ``f(rng, base) -> Case``; :data:`FAMILIES` maps names to them.
"""

from __future__ import annotations

import copy
import json
import math
import random
from collections.abc import Callable
from typing import Any

from . import tomlio
from .core import ELF_HEADER, Base, Case, binary_junk, dotted, pick, put, registrar, render

FAMILIES: dict[str, Callable[[random.Random, Base], Case]] = {}
"""The shape mutator families, by name, in definition order (each added by ``@mutator``)."""
mutator = registrar(FAMILIES)
Doc = dict[str, Any]
Edit = Callable[[Doc, dict[str, bytes]], str]


# --------------------------------------------------------------------------- map access

def map_points(base: Base, doc: Doc) -> tuple[list[list[float]], list[list[float]]]:
    """(landmarks, waypoints) of a planar/drone world, from the document or its map file."""
    mp = doc.get("map", {})
    if "file" in mp:
        raw = json.loads(dict(base.extra)[mp["file"]])
        return ([list(p) for p in zip(*raw["lm"])], [list(p) for p in zip(*raw["wp"])])
    return (copy.deepcopy(mp.get("landmarks", [])), copy.deepcopy(mp.get("waypoints", [])))


def set_map(doc: Doc, extra: dict[str, bytes], lm: list[list[float]] | None = None,
             wp: list[list[float]] | None = None) -> None:
    """Write landmarks/waypoints back where they came from (document or map file)."""
    mp = doc.setdefault("map", {})
    if "file" in mp:
        name = mp["file"]
        raw = json.loads(extra[name])
        if lm is not None:
            raw["lm"] = [[p[0] for p in lm], [p[1] for p in lm]]
        if wp is not None:
            raw["wp"] = [[p[0] for p in wp], [p[1] for p in wp]]
        extra[name] = json.dumps(raw).encode()
        return
    if lm is not None:
        mp["landmarks"] = lm
    if wp is not None:
        mp["waypoints"] = wp


def start_of(doc: Doc) -> tuple[list[float], float]:
    veh = doc.get("vehicle", {})
    xy = list(veh.get("start_xy_m", [0.0, 0.0]))
    return xy, math.radians(float(veh.get("start_heading_deg", 0.0)))


def edit_case(base: Base, family: str, name: str, edit: Callable[[Doc, dict[str, bytes]], Any]
          ) -> Case:
    doc, extra = copy.deepcopy(base.doc), dict(base.extra)
    edit(doc, extra)
    return render(base, family, name, doc, extra=extra)


def sets(*items: tuple[str, Any]) -> Callable[[Doc, dict[str, bytes]], None]:
    """An edit setting dotted keys (``"imu.rate_hz"``) to values."""
    def edit(d: Doc, e: dict[str, bytes]) -> None:
        for k, v in items:
            *head, last = k.split(".")
            t = d
            for h in head:
                t = t.setdefault(h, {})
            t[last] = v
    return edit


def _geometry_slam(rng: random.Random, base: Base) -> tuple[str, Callable[..., Any]]:
    doc = base.doc
    lm, wp = map_points(base, doc)
    (sx, sy), h = start_of(doc)
    side = rng.choice([2.0, 3.0, 5.0])
    inside = [sx - side * math.sin(h), sy + side * math.cos(h)]
    b = doc.get("map", {}).get("bounds_m", [0.0, 100.0, 0.0, 100.0])
    options: list[tuple[str, Callable[..., Any]]] = [
        ("waypoints all at the start", lambda d, e: set_map(d, e, wp=[[sx, sy]] * 3)),
        ("one waypoint, at the start", lambda d, e: set_map(d, e, wp=[[sx, sy]])),
        (f"waypoint {side} m beside the start (inside the turning circle)",
         lambda d, e: set_map(d, e, wp=[inside, *wp])),
        ("all landmarks at one point", lambda d, e: set_map(d, e, lm=[[50.0, 50.0]] * 5)),
        ("a landmark at the start", lambda d, e: set_map(d, e, lm=[[sx, sy], *lm])),
        ("no landmarks", lambda d, e: set_map(d, e, lm=[])),
        ("no waypoints", lambda d, e: set_map(d, e, wp=[])),
        ("waypoint on a landmark", lambda d, e: set_map(d, e, wp=[lm[0], *wp[1:]])),
        ("back-and-forth waypoints 1 m apart",
         lambda d, e: set_map(d, e, wp=[[sx + 1.0, sy], [sx, sy]] * 2)),
        ("waypoints 1e6 m away", lambda d, e: set_map(d, e, wp=[[1e6, 1e6], [sx, sy]])),
        ("two landmarks 1e-9 m apart",
         lambda d, e: set_map(d, e, lm=[lm[0], [lm[0][0] + 1e-9, lm[0][1]], *lm[1:]])),
        ("bounds inverted", sets(("map.bounds_m", [b[1], b[0], b[3], b[2]]))),
        ("bounds of zero area", sets(("map.bounds_m", [0.0, 0.0, 0.0, 0.0]))),
        ("start outside the bounds", sets(("vehicle.start_xy_m", [1e5, 1e5]))),
        ("at_waypoint_m = 100", sets(("vehicle.at_waypoint_m", 100.0))),
        ("sensor range 1e-9 m", sets(("sensor.max_range_m", 1e-9))),
    ]
    if base.kind == "drone-slam":
        options += [("min_range_m > max_range_m", sets(("sensor.min_range_m", 50.0))),
                    ("fov 1e-9 deg", sets(("sensor.fov_azimuth_half_deg", 1e-9))),
                    ("height_above_ground_m = 1e-9",
                     sets(("vehicle.height_above_ground_m", 1e-9)))]
    else:
        options += [("wheelbase_m = 1e-9", sets(("vehicle.wheelbase_m", 1e-9))),
                    ("max_steer_deg = 1e-9", sets(("vehicle.max_steer_deg", 1e-9)))]
    return rng.choice(options)


def _geometry_attitude(rng: random.Random) -> tuple[str, Callable[..., Any]]:
    def star(**kv: Any) -> Callable[..., Any]:
        return lambda d, e: d.setdefault("star_sensor", {}).update(kv)

    def sat(k: str, v: Any) -> Callable[..., Any]:
        return lambda d, e: d.setdefault("satellite", {}).__setitem__(k, v)

    def filt(k: str, v: Any) -> Callable[..., Any]:
        return lambda d, e: d.setdefault("filters", {}).__setitem__(k, v)

    return rng.choice([
        ("parallel star directions", star(mode="vectors", directions=[[1.0, 0, 0], [1.0, 0, 0]])),
        ("zero star direction", star(mode="vectors", directions=[[0.0, 0, 0], [0, 1.0, 0]])),
        ("1e-300 star direction", star(mode="vectors", directions=[[1e-300, 0, 0], [0, 1.0, 0]])),
        ("one star direction", star(mode="vectors", directions=[[1.0, 0, 0]])),
        ("star sigma 0", star(sigma_arcsec=0.0)),
        ("star rate above the gyro rate", star(rate_hz=1000.0)),
        ("no rotation at all", lambda d, e: (sat("initial_rate_deg_s", [0.0, 0, 0])(d, e),
                                              sat("orbital_rate_rad_s", 0.0)(d, e))),
        ("pitch 90 deg (Z-X-Y singularity)", sat("initial_attitude_deg", [0.0, 90.0, 0.0])),
        ("initial error 90 deg", filt("initial_error_deg", [90.0, 90.0, 90.0])),
        ("steady state after the end",
         lambda d, e: d.setdefault("scoring", {}).__setitem__("steady_state_from_s", 1e4)),
        ("duration shorter than a gyro step", lambda d, e: d.__setitem__("duration_s", 1e-9)),
    ])


@mutator("geometry")
def fam_geometry(rng: random.Random, base: Base) -> Case:
    """Degenerate geometry of the SLAM kinds' maps and paths, or of the attitude kind's
    star sensor; a kind with neither gets its degenerate settings from the attitude list
    (mostly unknown keys to it: refused, which is what the fuzzing checks then)."""
    lm, wp = map_points(base, base.doc) if "map" in base.doc else ([], [])
    if base.kind in ("planar-slam", "drone-slam") and lm and wp:
        name, edit = _geometry_slam(rng, base)
    else:
        name, edit = _geometry_attitude(rng)
    return edit_case(base, "geometry", name, edit)


# --------------------------------------------------------------------------- huge sizes

@mutator("huge-size")
def fam_huge(rng: random.Random, base: Base) -> Case:
    """In-range values whose product is a huge run: long, fine-grained or wide."""
    many = [[(i * 7.31) % 100.0, (i * 3.17) % 100.0] for i in range(20_000)]
    common: list[tuple[str, Callable[..., Any]]] = [
        ("speed_mps = 1e-300", sets(("vehicle.speed_mps", 1e-300))),
        ("speed_mps = 1e-6", sets(("vehicle.speed_mps", 1e-6))),
        ("loops = 100", sets(("vehicle.loops", 100))),
        ("20000 landmarks", lambda d, e: set_map(d, e, lm=many)),
    ]
    by_kind: dict[str, list[tuple[str, Callable[..., Any]]]] = {
        "planar-slam": common + [
            ("period_steps = 100000", sets(("sensor.period_steps", 100_000))),
            ("dt_s = 1e-6", sets(("vehicle.dt_s", 1e-6))),
            ("dt_s = 1e-308", sets(("vehicle.dt_s", 1e-308))),
            ("steer_rate_deg_s = 1e-308", sets(("vehicle.steer_rate_deg_s", 1e-308))),
            ("range 10000 m, 2000 landmarks, joint",
             sets(("sensor.max_range_m", 1e4), ("filters.mode", "joint"),
                   ("map.landmarks", many[:2000]), ("map.file", None))),
        ],
        "drone-slam": common + [
            ("imu rate_hz = 10000", sets(("imu.rate_hz", 10_000.0))),
            ("sensor rate_hz = 1000", sets(("sensor.rate_hz", 1000.0))),
            ("grid 0.1 m, margin 1e4 m", sets(("terrain.grid_spacing_m", 0.1),
                                               ("terrain.margin_m", 1e4))),
            ("altitude_smoothing_s = 1e-308", sets(("vehicle.altitude_smoothing_s", 1e-308))),
            ("max_turn_accel_deg_s2 = 1e-300", sets(("vehicle.max_turn_accel_deg_s2", 1e-300))),
            ("100 hills", sets(("terrain.type", "hills"), ("terrain.hill_amplitude_m", 5.0),
                                ("terrain.hill_width_m", 9.0),
                                ("terrain.hill_centres_m", many[:100]))),
        ],
        "attitude": [
            ("gyro 10000 Hz for 86400 s", sets(("gyro.rate_hz", 10_000.0),
                                                ("duration_s", 86_400.0))),
            ("star 1000 Hz for 86400 s", sets(("star_sensor.rate_hz", 1000.0),
                                               ("duration_s", 86_400.0))),
            ("duration_s = 86400", sets(("duration_s", 86_400.0))),
            ("gyro rate_hz = 1e-300", sets(("gyro.rate_hz", 1e-300))),
            ("star rate_hz = 1e-300", sets(("star_sensor.rate_hz", 1e-300))),
        ],
    }
    name, edit = rng.choice(by_kind.get(base.kind, common))

    def apply(d: Doc, e: dict[str, bytes]) -> None:
        edit(d, e)
        mp = d.get("map", {})
        if mp.get("file", 0) is None:  # "map.file = None" above: use inline landmarks
            mp.pop("file")
            _, wp = map_points(base, base.doc)
            mp.setdefault("waypoints", wp)

    return edit_case(base, "huge-size", name, apply)


# --------------------------------------------------------------------------- files

_MESHES: dict[str, bytes] = {
    "junk.obj": b"this is not a mesh\nv 1 2\nf 9 9 9\n",
    "empty.obj": b"",
    "degenerate.obj": b"v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3\n",
    "far.obj": b"v 1e6 1e6 0\nv 1e6 1.1e6 0\nv 1.1e6 1e6 0\nf 1 2 3\n",
    "nan.obj": b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "junk.stl": bytes(range(256)) * 8,
    "map.glb": b'{"lm": [[1], [2]]}',
}
_MAPS: dict[str, bytes] = {
    "junk.json": bytes(range(256)) * 4,
    "list.json": b"[]",
    "short.json": b'{"lm": [[1.0, 2.0]]}',
    "strings.json": b'{"lm": "x", "wp": "y"}',
    "ragged.json": b'{"lm": [[1.0, 2.0], [3.0]], "wp": [[0.0, 10.0], [0.0, 0.0]]}',
    "nan.json": b'{"lm": [[NaN, 2.0], [1.0, Infinity]], "wp": [[0.0, 10.0], [0.0, 0.0]]}',
    "empty.json": b'{"lm": [[], []], "wp": [[], []]}',
    "deep.json": b"[" * 100_000 + b"]" * 100_000,
    "huge-number.json": b'{"lm": [[1e999], [1]], "wp": [[0.0, 10.0], [0.0, 0.0]]}',
}
_PATHS = ("/dev/zero", "/dev/null", "/etc/passwd", "missing.json", ".", "",
          "../../../../../../../etc/hostname")


@mutator("files")
def fam_files(rng: random.Random, base: Base) -> Case:
    """Map and mesh files that are not what the key says."""
    doc, extra = copy.deepcopy(base.doc), dict(base.extra)
    if base.kind == "drone-slam":
        name = rng.choice([*_MESHES, "/dev/zero", ".", "missing.obj", "/etc/passwd"])
        if name in _MESHES:
            extra[name] = _MESHES[name]
        ter = doc.setdefault("terrain", {})
        for k in [k for k in ter if k.startswith("hill_") or k == "grid_spacing_m"]:
            del ter[k]
        ter.update(type="mesh", mesh_file=name)
        return render(base, "files", f'terrain mesh_file = "{name}"', doc, extra=extra)
    if base.kind == "planar-slam":
        name = rng.choice([*_MAPS, *_PATHS])
        if name in _MAPS:
            extra[name] = _MAPS[name]
        mp = doc.setdefault("map", {})
        keep_inline = rng.random() < 0.2
        if not keep_inline:
            mp.pop("landmarks", None)
            mp.pop("waypoints", None)
        mp["file"] = name
        both = " (and inline points)" if keep_inline and "landmarks" in mp else ""
        return render(base, "files", f'map.file = "{name}"{both}', doc, extra=extra)
    key = rng.choice(["file", "map_file"])
    doc[key] = "/dev/zero"
    return render(base, "files", f'{key} = "/dev/zero" (no such key)', doc)


# --------------------------------------------------------------------------- raw text

@mutator("binary")
def fam_binary(rng: random.Random, base: Base) -> Case:
    text = tomlio.dumps(base.doc).encode()
    at = rng.randrange(len(text))
    name, data = rng.choice([
        *binary_junk(rng, text, at),
        ("empty file", b""),
        ("truncated", text[:at]),
        ("CRLF line ends", text.replace(b"\n", b"\r\n")),
        ("lone CR line ends", text.replace(b"\n", b"\r")),
        ELF_HEADER,
    ])
    return render(base, "binary", f"{name} (at byte {at})", text=data)


def _deep(style: str, depth: int) -> str:
    if style == "arrays":
        return "[" * depth + "0" + "]" * depth
    return "{a = " * depth + "0" + "}" * depth


@mutator("nesting")
def fam_nesting(rng: random.Random, base: Base) -> Case:
    depth = rng.choice([64, 1000, 10_000, 100_000])
    style = rng.choice(["arrays", "inline tables", "table headers"])
    text = tomlio.dumps(base.doc)
    if style == "table headers":
        text += "\n[" + ".".join(["deep"] * depth) + "]\nx = 1\n"
        return render(base, "nesting", f"table header {depth} deep", text=text)
    line = f"deep = {_deep(style, depth)}\n"
    lines = text.splitlines(keepends=True)
    where = "top level"
    if "[paper]\n" in lines and rng.random() < 0.6:
        lines.insert(lines.index("[paper]\n") + 1, line)  # [paper] is free-form
        where = "[paper]"
    else:
        lines.insert(0, line)
    return render(base, "nesting", f"{style} {depth} deep in {where}", text="".join(lines))


@mutator("syntax")
def fam_syntax(rng: random.Random, base: Base) -> Case:
    text = tomlio.dumps(base.doc)
    lines = text.splitlines(keepends=True)
    assigns = [i for i, ln in enumerate(lines) if " = " in ln]
    i = rng.choice(assigns)
    at = rng.randrange(len(text))
    name, new = rng.choice([
        ("duplicated key", "".join(lines[: i + 1] + [lines[i]] + lines[i + 1:])),
        ("unterminated string", text + 'broken = "unterminated\n'),
        ("key without value", text + "x =\n"),
        ("unclosed header", text + "[vehicle\n"),
        ("duplicated section", text + f"\n[{next(iter(_tables(base.doc)), 'x')}]\n"),
        ("invalid escape", text + 'bad = "\\q"\n'),
        ("value without key", text + "= 3\n"),
        ("one character deleted", text[:at] + text[at + 1:]),
        ("truncated mid-file", text[:at]),
        ("two equals signs", "".join(lines[:i] + [lines[i].replace(" = ", " = = ")] +
                                     lines[i + 1:])),
    ])
    return render(base, "syntax", name, text=new)


def _tables(doc: Doc) -> list[str]:
    return [k for k, v in doc.items() if isinstance(v, dict)]


_STRINGS = ("x" * 1_000_000, "", "a\nb", "\x00", "\u202eevil", "🚀" * 50, "   ", "٣",
            "planar-slam\n", "nan")


@mutator("strings")
def fam_strings(rng: random.Random, base: Base) -> Case:
    doc = copy.deepcopy(base.doc)
    path = pick(rng, doc, lambda v: isinstance(v, str)) or ("description",)
    new = rng.choice(_STRINGS)
    put(doc, path, new)
    shown = new if len(new) < 20 else f"{new[:5]}...({len(new)} chars)"
    return render(base, "strings", f"{dotted(path)} = {shown!r}", doc)

