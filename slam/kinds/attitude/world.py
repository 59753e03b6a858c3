"""The ``attitude`` world: satellite attitude from a strapdown gyro and a star sensor.

Seed 004 §5.1-5.2 (SCENARIOS.md S3).  Units are spelled in every key and converted to SI
radians on load; the dataclasses name their SI units.  File layout::

    kind = "attitude"
    description = "one line"
    runs = 50                      # Monte Carlo runs
    seed = 0                       # optional
    duration_s = 600.0
    [satellite]    orbit_height_km, inclination_deg, orbital_rate_rad_s,
                   initial_attitude_deg = [roll, pitch, yaw] (paper's Z-X-Y sequence),
                   initial_rate_deg_s = [x, y, z] (body rate relative to the orbit frame)
    [gyro]         rate_hz, bias_deg_h = [x, y, z] (constant drift at t = 0),
                   bias_rw_deg_h_sqrt_h (rate random walk), arw_deg_sqrt_h (angle random walk)
    [star_sensor]  rate_hz, sigma_arcsec, mode ("quaternion" | "vectors"), n_stars,
                   directions (optional nav-frame reference star directions, vector mode)
    [filters]      names, initial_error_deg = [roll, pitch, yaw], initial_attitude_var_deg2,
                   initial_bias_var_deg_h2, arw_deg_sqrt_h, bias_rw_deg_h_sqrt_h,
                   star_sigma_arcsec (the noises the filters and the smoother assume)
    [scoring]      steady_state_from_s, report_convergence, divergence_deg
    [paper]        free-form: the paper's reported numbers, passed through to summary.json

The navigation frame is inertial and coincides with the orbit (LVLH) frame at t = 0;
see :mod:`slam.kinds.attitude.simulate` for the motion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib.resources.abc import Traversable
from typing import Any

import numpy as np

from estimators.filters import FILTER_NAMES  # the one list of filter names
from worlds.schema import (
    Boolean,
    Field,
    FreeForm,
    Integer,
    Interval,
    Number,
    Section,
    String,
    StringList,
    Vector,
    Where,
    positive,
    read_table,
)

KIND = "attitude"
STAR_MODES = ("quaternion", "vectors")

DEG = math.pi / 180.0
ARCSEC = DEG / 3600.0
DEG_H = DEG / 3600.0  # deg/h -> rad/s
DEG_SQRT_H = DEG / 60.0  # deg/sqrt(h) -> rad/sqrt(s)
DEG_H_SQRT_H = DEG / 3600.0 / 60.0  # (deg/h)/sqrt(h) -> rad/s/sqrt(s)

#: Reference star directions used in vector mode when the file gives none (nav frame,
#: normalised on load): well spread, no two closer than 60 degrees.
DEFAULT_STAR_DIRECTIONS = (
    (1.0, 0.2, 0.3),
    (-0.2, 1.0, 0.4),
    (0.1, -0.3, 1.0),
    (-1.0, -0.5, 0.2),
    (0.4, -1.0, -0.6),
    (-0.3, 0.5, -1.0),
)


class Directions(Field):
    """A list of ``[x, y, z]`` non-zero direction vectors -> tuple of unit 3-tuples."""

    def __init__(self, default: Any = None) -> None:
        self.default = default

    def parse(self, value: Any, where: Where) -> tuple[tuple[float, float, float], ...]:
        if not isinstance(value, list) or not value:
            raise where.error("must be a non-empty list of [x, y, z] directions", value)
        out = []
        for i, v in enumerate(value):
            ok = (isinstance(v, list) and len(v) == 3
                  and all(isinstance(c, int | float) and not isinstance(c, bool)
                          and math.isfinite(c) for c in v))
            if not ok:
                raise where.item(i).error("must be an [x, y, z] triple of finite numbers", v)
            n = math.sqrt(sum(c * c for c in v))
            if not n > 1e-9:
                raise where.item(i).error("must be a non-zero direction", v)
            out.append((v[0] / n, v[1] / n, v[2] / n))
        return tuple(out)


SCHEMA = {
    "kind": String(choices=(KIND,)),
    "description": String(one_line=True, max_len=200),
    "runs": Integer(Interval(1, 100_000)),
    "seed": Integer(Interval(0, 2**63 - 1), default=0),
    "duration_s": Number(positive(86_400.0)),
    "satellite": Section(
        {
            "orbit_height_km": Number(positive(100_000.0)),
            "inclination_deg": Number(Interval(0.0, 180.0), scale=DEG),
            "orbital_rate_rad_s": Number(Interval(0.0, 0.1)),
            "initial_attitude_deg": Vector(3, Interval(-180.0, 180.0)),
            "initial_rate_deg_s": Vector(3, Interval(-30.0, 30.0)),
        }
    ),
    "gyro": Section(
        {
            "rate_hz": Number(positive(10_000.0)),
            "bias_deg_h": Vector(3, Interval(-3600.0, 3600.0)),
            "bias_rw_deg_h_sqrt_h": Number(Interval(0.0, 100.0), scale=DEG_H_SQRT_H),
            "arw_deg_sqrt_h": Number(Interval(0.0, 100.0), scale=DEG_SQRT_H),
        }
    ),
    "star_sensor": Section(
        {
            "rate_hz": Number(positive(1_000.0)),
            "sigma_arcsec": Number(Interval(0.0, 36_000.0), scale=ARCSEC),
            "mode": String(choices=STAR_MODES, default="quaternion"),
            "n_stars": Integer(Interval(2, len(DEFAULT_STAR_DIRECTIONS)), default=2),
            "directions": Directions(default=None),
        }
    ),
    "filters": Section(
        {
            "names": StringList(FILTER_NAMES),
            "initial_error_deg": Vector(3, Interval(-90.0, 90.0)),
            "initial_attitude_var_deg2": Number(positive(1e4), scale=DEG**2),
            "initial_bias_var_deg_h2": Number(positive(1e8), scale=DEG_H**2),
            "arw_deg_sqrt_h": Number(positive(100.0), scale=DEG_SQRT_H),
            "bias_rw_deg_h_sqrt_h": Number(positive(100.0), scale=DEG_H_SQRT_H),
            "star_sigma_arcsec": Number(positive(36_000.0), scale=ARCSEC),
        }
    ),
    "scoring": Section(
        {
            "steady_state_from_s": Number(Interval(0.0, 86_400.0)),
            "report_convergence": Boolean(default=False),
            "divergence_deg": Number(positive(180.0), default=1.0, scale=DEG),
        }
    ),
    "paper": FreeForm(default=dict),
}


@dataclass(frozen=True)
class SatelliteSpec:
    """Orbit (metadata except the rate) and the satellite's initial state (radians).

    ``initial_attitude_rad`` is ``[roll, pitch, yaw]`` in the paper's Z-X-Y sequence,
    relative to the navigation frame (= orbit frame at t = 0); ``initial_rate_rad_s`` is
    the body rate relative to the orbit frame, held constant.
    """

    orbit_height_km: float
    inclination_rad: float
    orbital_rate_rad_s: float
    initial_attitude_rad: tuple[float, float, float]
    initial_rate_rad_s: tuple[float, float, float]


@dataclass(frozen=True)
class GyroSpec:
    """Strapdown gyro: ``ω_meas = ω_true + b(t) + n``.

    ``bias_rad_s`` is b(0) per axis; ``bias_rw_rad_s_sqrt_s`` the rate-random-walk density
    (b gets σ·√dt per sample); ``arw_rad_sqrt_s`` the angle-random-walk density (n has
    σ/√dt per sample).
    """

    rate_hz: float
    bias_rad_s: tuple[float, float, float]
    bias_rw_rad_s_sqrt_s: float
    arw_rad_sqrt_s: float

    @property
    def dt_s(self) -> float:
        return 1.0 / self.rate_hz


@dataclass(frozen=True)
class StarSensorSpec:
    """Star sensor: a noisy attitude quaternion (σ per axis, body frame) or ``n_stars``
    unit vectors ``C(q)ᵀ r_j`` with σ per tangent-plane axis.  ``directions`` are the
    nav-frame reference vectors ``r_j`` (unit, ``n_stars`` of them)."""

    rate_hz: float
    sigma_rad: float
    mode: str
    n_stars: int
    directions: tuple[tuple[float, float, float], ...]


@dataclass(frozen=True)
class AttitudeFilterSpec:
    """Filters to run and what they (and the smoother) assume.

    ``initial_error_rad``: the estimate starts at the truth's Z-X-Y Euler angles plus this
    ``[roll, pitch, yaw]`` error; the bias estimate starts at zero.  Variances are in
    rad² and (rad/s)²; noise densities as in :class:`GyroSpec`.
    """

    names: tuple[str, ...]
    initial_error_rad: tuple[float, float, float]
    initial_attitude_var_rad2: float
    initial_bias_var_rad2_s2: float
    arw_rad_sqrt_s: float
    bias_rw_rad_s_sqrt_s: float
    star_sigma_rad: float

    @property
    def mode(self) -> str:
        """Always ``"joint"``: one state, no map to split (read by the CLI for every kind)."""
        return "joint"


@dataclass(frozen=True)
class ScoringSpec:
    """``steady_state_from_s``: start of the steady-state statistics window;
    ``report_convergence``: report the time after which the attitude error stays
    below 1′; a run whose final attitude error exceeds ``divergence_rad`` is diverged."""

    steady_state_from_s: float
    report_convergence: bool = False
    divergence_rad: float = 1.0 * DEG


@dataclass(frozen=True)
class AttitudeWorld:
    """A validated attitude world.  ``paper`` is free-form (JSON-compatible)."""

    name: str
    kind: str
    description: str
    duration_s: float
    satellite: SatelliteSpec
    gyro: GyroSpec
    star: StarSensorSpec
    filters: AttitudeFilterSpec
    scoring: ScoringSpec
    runs: int
    seed: int = 0
    paper: dict[str, Any] = field(default_factory=dict)
    source: str = ""

    @property
    def samples_per_star(self) -> int:
        """Gyro samples per star-sensor interval."""
        return int(round(self.gyro.rate_hz / self.star.rate_hz))

    @property
    def n_star(self) -> int:
        """Star epochs, the first at t = 0."""
        return int(round(self.duration_s * self.star.rate_hz)) + 1


def _is_whole(x: float, tol: float = 1e-9) -> bool:
    return abs(x - round(x)) <= tol * max(1.0, abs(x))


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None
          ) -> AttitudeWorld:
    """Validate a parsed ``attitude`` TOML document and build its :class:`AttitudeWorld`."""
    root = Where(source, "")
    v = read_table(data, SCHEMA, root)
    sat, gyr, star, fil, sco = (v["satellite"], v["gyro"], v["star_sensor"], v["filters"],
                                v["scoring"])

    ratio = gyr["rate_hz"] / star["rate_hz"]
    if not (_is_whole(ratio) and round(ratio) >= 1):
        raise root.child("star_sensor.rate_hz").error(
            f"must divide the gyro rate ({gyr['rate_hz']:g} Hz) a whole number of times",
            star["rate_hz"])
    if not (_is_whole(v["duration_s"] * star["rate_hz"]) and v["duration_s"] * star["rate_hz"]
            >= 1):
        raise root.child("duration_s").error(
            f"must be a whole number (>= 1) of star-sensor periods ({1 / star['rate_hz']:g} s)",
            v["duration_s"])
    if sco["steady_state_from_s"] >= v["duration_s"]:
        raise root.child("scoring.steady_state_from_s").error(
            f"must be below duration_s ({v['duration_s']:g})", sco["steady_state_from_s"])

    at_star = root.child("star_sensor")
    dirs = star["directions"]
    if dirs is None:
        raw = np.array(DEFAULT_STAR_DIRECTIONS[: star["n_stars"]], dtype=float)
        dirs = tuple(tuple(float(c) for c in r / np.linalg.norm(r)) for r in raw)
    elif len(dirs) != star["n_stars"]:
        raise at_star.child("directions").error(
            f"must list n_stars = {star['n_stars']} directions", [list(d) for d in dirs])
    if star["mode"] == "vectors":
        d = np.array(dirs)
        if np.linalg.matrix_rank(d, tol=1e-3) < 2:
            raise at_star.child("directions").error(
                "must hold at least two non-parallel directions", [list(x) for x in dirs])

    deg3 = tuple(float(x) * DEG for x in sat["initial_attitude_deg"])
    return AttitudeWorld(
        name=name,
        kind=v["kind"],
        description=v["description"],
        duration_s=v["duration_s"],
        satellite=SatelliteSpec(
            orbit_height_km=sat["orbit_height_km"],
            inclination_rad=sat["inclination_deg"],
            orbital_rate_rad_s=sat["orbital_rate_rad_s"],
            initial_attitude_rad=deg3,  # type: ignore[arg-type]
            initial_rate_rad_s=tuple(float(x) * DEG for x in sat["initial_rate_deg_s"]),
        ),
        gyro=GyroSpec(
            rate_hz=gyr["rate_hz"],
            bias_rad_s=tuple(float(x) * DEG_H for x in gyr["bias_deg_h"]),  # type: ignore
            bias_rw_rad_s_sqrt_s=gyr["bias_rw_deg_h_sqrt_h"],
            arw_rad_sqrt_s=gyr["arw_deg_sqrt_h"],
        ),
        star=StarSensorSpec(
            rate_hz=star["rate_hz"],
            sigma_rad=star["sigma_arcsec"],
            mode=star["mode"],
            n_stars=star["n_stars"],
            directions=dirs,
        ),
        filters=AttitudeFilterSpec(
            names=fil["names"],
            initial_error_rad=tuple(float(x) * DEG for x in fil["initial_error_deg"]),
            initial_attitude_var_rad2=fil["initial_attitude_var_deg2"],
            initial_bias_var_rad2_s2=fil["initial_bias_var_deg_h2"],
            arw_rad_sqrt_s=fil["arw_deg_sqrt_h"],
            bias_rw_rad_s_sqrt_s=fil["bias_rw_deg_h_sqrt_h"],
            star_sigma_rad=fil["star_sigma_arcsec"],
        ),
        scoring=ScoringSpec(
            steady_state_from_s=sco["steady_state_from_s"],
            report_convergence=sco["report_convergence"],
            divergence_rad=sco["divergence_deg"],
        ),
        runs=v["runs"],
        seed=v["seed"],
        paper=v["paper"],
        source=source,
    )
