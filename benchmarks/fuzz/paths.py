"""The ``degenerate-path`` world family: valid worlds whose motion leaves a summary with
nothing to average over, or a calibration with no solution.

* planar and drone: every waypoint the same point (a zero-length loop), two identical
  consecutive waypoints, the closing leg of zero length, every waypoint doubled;
* spinning: a launch at 89 deg or 1 deg, a launch speed of 1e-300 ... 1 m/s, flight
  targets that no drag constant meets (range beyond the vacuum range, apex above it,
  a flight time of 1 s), no atmosphere;
* fixed-wing: no turns, no accelerating epochs, straight and level, GNSS at 0.01 Hz
  (with and without turns), one manoeuvre for the whole flight;
* alignment and ship: no sway / no waves, a site at the latitude limit;
* attitude: no rotation, pitch exactly 90 deg.

The expected outcome is a refusal naming the key, or a summary whose every null has its
reason (and no numpy warning on the terminal): the classifier's ``unexplained-null`` and
``warning-printed`` classes, and tracebacks from an empty ``nanmax``.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from typing import Any

from .core import Base, Case, registrar
from .shapes import Doc, edit_case, map_points, set_map, sets, start_of

FAMILIES: dict[str, Callable[[random.Random, Base], Case]] = {}
"""The family of this module, by name."""
mutator = registrar(FAMILIES)
Option = tuple[str, Callable[[Doc, dict[str, bytes]], Any]]


def _slam_paths(rng: random.Random, base: Base) -> list[Option]:
    lm, wp = map_points(base, base.doc)
    (sx, sy), _ = start_of(base.doc)
    if not wp:
        wp = [[sx + 10.0, sy], [sx + 10.0, sy + 10.0]]
    k = rng.randrange(len(wp))
    p = wp[k]
    n = rng.choice([2, 3, 10])

    def with_wp(new: list[list[float]]) -> Callable[[Doc, dict[str, bytes]], None]:
        return lambda d, e: set_map(d, e, wp=new)

    return [
        (f"{n} waypoints all at waypoint {k} (a zero-length loop)", with_wp([p] * n)),
        (f"{n} waypoints all at the start (a zero-length loop)", with_wp([[sx, sy]] * n)),
        (f"waypoint {k} repeated (two identical consecutive waypoints)",
         with_wp([*wp[:k + 1], p, *wp[k + 1:]])),
        ("last waypoint equal to the first (a zero-length closing leg)",
         with_wp([*wp, wp[0]])),
        ("every waypoint doubled", with_wp([q for w in wp for q in (w, w)])),
        ("two waypoints, identical, one loop",
         lambda d, e: (set_map(d, e, wp=[p, p]), sets(("vehicle.loops", 1))(d, e))),
        ("waypoints 1e-9 m apart", with_wp([p, [p[0] + 1e-9, p[1]]])),
    ]


def _spinning(doc: Doc) -> list[Option]:
    launch = doc.get("launch", {})
    flight = doc.get("flight", {})
    v = float(launch.get("speed_mps", 897.0))
    vacuum = v * v / 9.80665  # the longest range without drag at 45 deg
    return [
        ("launch pitch 89 deg (straight up)", sets(("launch.pitch_deg", 89.0))),
        ("launch pitch 1 deg (skims the ground)", sets(("launch.pitch_deg", 1.0))),
        ("launch speed 1e-300 m/s", sets(("launch.speed_mps", 1e-300))),
        ("launch speed 1e-6 m/s", sets(("launch.speed_mps", 1e-6))),
        ("launch speed 1 m/s", sets(("launch.speed_mps", 1.0))),
        ("target range beyond the vacuum range",
         sets(("flight.target_range_m", min(1e6, 3.0 * vacuum)))),
        ("target apex above the range, flight time 1 s",
         sets(("flight.target_apex_m", 5e5), ("flight.target_range_m", 10.0),
              ("flight.target_flight_time_s", 1.0))),
        ("targets of a 1000 s flight to 10 m", sets(("flight.target_flight_time_s", 1000.0),
                                                    ("flight.target_range_m", 10.0))),
        ("drag given as 0 (vacuum) with the targets",
         sets(("flight.drag_k_per_m", 0.0))),
        ("drag at its bound 1e-2 /m", sets(("flight.drag_k_per_m", 1e-2))),
        ("no atmosphere (scale height 1e-300 m)", sets(("flight.scale_height_m", 1e-300))),
        ("no spin", sets(("spin.rate_rev_s", 0.0))),
        ("spin decays in 1e-300 s", sets(("spin.decay_time_s", 1e-300))),
        ("targets doubled but speed kept",
         sets(*[(f"flight.{k}", 2.0 * float(flight.get(k, 1.0)))
                for k in ("target_flight_time_s", "target_range_m", "target_apex_m")])),
    ]


def _fixed_wing(doc: Doc) -> list[Option]:
    fl = doc.get("flight", {})
    n = len(fl.get("manoeuvre_start_s", [0.0]))
    v0 = float(fl.get("start_speed_mps", 20.0))
    dur = float(doc.get("duration_s", 500.0))
    no_turns = ("flight.turn_rate_deg_s", [0.0] * n)
    steady = [no_turns, ("flight.climb_deg", [0.0] * n), ("flight.speed_mps", [v0] * n)]
    one = [("flight.manoeuvre_start_s", [0.0]), ("flight.manoeuvre_ramp_s", [1.0]),
           ("flight.climb_deg", [0.0]), ("flight.speed_mps", [v0])]
    gnss_rate = 0.01 if math.isclose(dur * 0.01, round(dur * 0.01)) else 1.0 / dur
    return [
        ("no turns", sets(no_turns)),
        ("no accelerating epochs (constant speed, no climb or turn)", sets(*steady)),
        ("straight and level from the start, constant speed",
         sets(*steady, ("flight.start_climb_deg", 0.0))),
        (f"GNSS at {gnss_rate:g} Hz", sets(("gnss.rate_hz", gnss_rate))),
        (f"GNSS at {gnss_rate:g} Hz, no turns", sets(("gnss.rate_hz", gnss_rate), no_turns)),
        ("one 10 deg/s turn for the whole flight",
         sets(*one, ("flight.turn_rate_deg_s", [10.0]))),
        ("EA updates at 0.1 Hz", sets(("ea.update_rate_hz", 0.1))),
        ("turn threshold above every turn", sets(("scoring.turn_rate_deg_s", 30.0))),
        ("acceleration threshold 10 m/s^2", sets(("scoring.accel_mps2", 10.0))),
    ]


def _alignment() -> list[Option]:
    still = [("sway.elevation_amplitude_deg", 0.0), ("sway.roll_amplitude_deg", 0.0)]
    calm = [("wind.mean_mps", [0.0, 0.0]), ("wind.amplitude_x_mps", [0.0] * 3),
            ("wind.amplitude_y_mps", [0.0] * 3), ("wind.compliance_m_per_mps", 0.0)]
    return [
        ("no sway", sets(*still)),
        ("no sway and no wind", sets(*still, *calm)),
        ("site at latitude 85 deg (azimuth near unobservable)", sets(("site.latitude_deg", 85.0))),
        ("site at latitude 0", sets(("site.latitude_deg", 0.0))),
        ("sway at 100 Hz", sets(("sway.elevation_frequency_hz", 100.0),
                                ("sway.roll_frequency_hz", 100.0))),
    ]


def _ship() -> list[Option]:
    calm = [(f"waves.{a}_amplitude_deg", 0.0) for a in ("roll", "pitch", "yaw")]
    return [
        ("no waves", sets(*calm)),
        ("site at latitude 89 deg", sets(("site.latitude_deg", 89.0))),
        ("no waves at latitude 89 deg", sets(*calm, ("site.latitude_deg", 89.0))),
        ("wave periods 0.5 s", sets(*[(f"waves.{a}_period_s", 0.5)
                                      for a in ("roll", "pitch", "yaw")])),
    ]


def _attitude() -> list[Option]:
    return [
        ("no rotation", sets(("satellite.initial_rate_deg_s", [0.0, 0.0, 0.0]),
                             ("satellite.orbital_rate_rad_s", 0.0))),
        ("pitch exactly 90 deg", sets(("satellite.initial_attitude_deg", [0.0, 90.0, 0.0]))),
        ("steady state from the last second",
         lambda d, e: d.setdefault("scoring", {}).__setitem__(
             "steady_state_from_s", float(d.get("duration_s", 40.0)))),
    ]


@mutator("degenerate-path")
def fam_degenerate_path(rng: random.Random, base: Base) -> Case:
    """A motion with nothing to average over or a calibration with no solution, in the
    base's own kind (see the module docstring)."""
    kind = base.kind
    options: list[Option]
    if kind in ("planar-slam", "drone-slam"):
        options = _slam_paths(rng, base)
    elif kind == "spinning":
        options = _spinning(base.doc)
    elif kind == "fixed-wing":
        options = _fixed_wing(base.doc)
    elif kind == "alignment":
        options = _alignment()
    elif kind == "ship":
        options = _ship()
    else:
        options = _attitude()
    name, edit = rng.choice(options)
    return edit_case(base, "degenerate-path", name, edit)
