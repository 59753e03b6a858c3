"""The ``attitude`` world: satellite attitude from a strapdown gyro and a star sensor.

[Wang SRCKF-SLAM] §5.1-5.2 (docs/kinds/star-sensor.md).  Units are spelled in every key
and converted to SI radians on load; the dataclasses name their SI units.  File layout::

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
                   star_sigma_arcsec (the noises the filters and the smoother assume);
                   [filters.unscented] / [filters.central_difference] (the SRUKF's α, β, κ
                   and the SRCDKF's h, required when those filters run: worlds.common)
    [scoring]      steady_state_from_s, report_convergence, divergence_deg
    [paper]        free-form: the paper's reported numbers, passed through to summary.json

The navigation frame is inertial and coincides with the orbit (LVLH) frame at t = 0;
see :mod:`slam.kinds.attitude.simulate` for the motion.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from typing import Any

import numpy as np

import worlds.common as wc
import worlds.schema as ws
from estimators.filters import FILTER_NAMES  # the one list of filter names
from worlds import limits
from worlds.units import ARCSEC, DEG, DEG_H, DEG_H_SQRT_H, DEG_SQRT_H

KIND = "attitude"
STAR_MODES = ("quaternion", "vectors")

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


class Directions(ws.Field):
    """A list of ``[x, y, z]`` non-zero direction vectors -> tuple of unit 3-tuples."""

    def __init__(self, default: Any = None) -> None:
        self.default = default

    def parse(self, value: Any, where: ws.Where) -> tuple[tuple[float, float, float], ...]:
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
class GyroSpec(wc.Sampled):
    """Strapdown gyro: ``ω_meas = ω_true + b(t) + n``.

    ``bias_rad_s`` is b(0) per axis; ``bias_rw_rad_s_sqrt_s`` the rate-random-walk density
    (b gets σ·√dt per sample); ``arw_rad_sqrt_s`` the angle-random-walk density (n has
    σ/√dt per sample).
    """

    rate_hz: float
    bias_rad_s: tuple[float, float, float]
    bias_rw_rad_s_sqrt_s: float
    arw_rad_sqrt_s: float


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
class AttitudeFilterSpec(wc.JointOnly, wc.TunedFilters):
    """Filters to run, their settings tables, and what they (and the smoother) assume.

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


@dataclass(frozen=True)
class ScoringSpec:
    """``steady_state_from_s``: start of the steady-state statistics window;
    ``report_convergence``: report the time after which the attitude error stays
    below 1′; a run whose final attitude error exceeds ``divergence_rad`` is diverged."""

    steady_state_from_s: float
    report_convergence: bool = False
    divergence_rad: float = 1.0 * DEG


@dataclass(frozen=True)
class AttitudeWorld(wc.WorldBase):
    """A validated attitude world."""

    duration_s: float
    satellite: SatelliteSpec
    gyro: GyroSpec
    star: StarSensorSpec
    filters: AttitudeFilterSpec
    scoring: ScoringSpec

    samples_per_star = wc.per_epoch("gyro", "star", "gyro samples per star-sensor interval")
    n_star = wc.epoch_count("star", "star epochs, the first at t = 0")


PAPER = {"statement": ws.TEXT, "large_error.statement": ws.TEXT,
         **{f"filters.*.{k}": ws.REAL
            for k in ("roll_arcsec", "pitch_arcsec", "yaw_arcsec", "time_per_iteration_s")}}
"""The ``[paper]`` keys the report reads (Table 2 per filter, the statements)."""

WORLD = wc.world(KIND, AttitudeWorld, {
    "duration_s": ws.Number(ws.positive(86_400.0)),
    "satellite": ws.Section(
        {
            "orbit_height_km": ws.Number(ws.positive(100_000.0)),
            "inclination_deg": ws.Number(ws.Interval(0.0, 180.0), scale=DEG).to("inclination_rad"),
            "orbital_rate_rad_s": ws.Number(ws.Interval(0.0, 0.1)),
            "initial_attitude_deg": ws.Vector(3, ws.Interval(-180.0, 180.0), scale=DEG)
            .to("initial_attitude_rad"),
            "initial_rate_deg_s": ws.Vector(3, ws.Interval(-30.0, 30.0), scale=DEG)
            .to("initial_rate_rad_s"),
        },
        into=SatelliteSpec,
    ),
    "gyro": ws.Section(
        {
            "rate_hz": ws.Number(ws.positive(10_000.0)),
            "bias_deg_h": ws.Vector(3, ws.Interval(-3600.0, 3600.0), scale=DEG_H).to("bias_rad_s"),
            "bias_rw_deg_h_sqrt_h": wc.nonnegative(100.0, DEG_H_SQRT_H, "bias_rw_rad_s_sqrt_s"),
            "arw_deg_sqrt_h": wc.nonnegative(100.0, DEG_SQRT_H, "arw_rad_sqrt_s"),
        },
        into=GyroSpec,
    ),
    "star_sensor": ws.Section(
        {
            "rate_hz": ws.Number(ws.positive(1_000.0)),
            "sigma_arcsec": ws.Sigma(ws.Interval(0.0, 36_000.0), scale=ARCSEC).to("sigma_rad"),
            "mode": ws.String(choices=STAR_MODES, default="quaternion"),
            "n_stars": ws.Integer(ws.Interval(2, len(DEFAULT_STAR_DIRECTIONS)), default=2),
            "directions": Directions(default=None),
        },
        into=StarSensorSpec,
    ).to("star"),
    "filters": ws.Section(
        {
            "names": ws.StringList(FILTER_NAMES),
            "initial_error_deg": ws.Vector(3, ws.Interval(-90.0, 90.0), scale=DEG)
            .to("initial_error_rad"),
            "initial_attitude_var_deg2": ws.Sigma(ws.positive(1e4), scale=DEG**2, power=1)
            .to("initial_attitude_var_rad2"),
            "initial_bias_var_deg_h2": ws.Sigma(ws.positive(1e8), scale=DEG_H**2, power=1)
            .to("initial_bias_var_rad2_s2"),
            "arw_deg_sqrt_h": ws.Sigma(ws.positive(100.0), scale=DEG_SQRT_H).to("arw_rad_sqrt_s"),
            "bias_rw_deg_h_sqrt_h": ws.Sigma(ws.positive(100.0), scale=DEG_H_SQRT_H)
            .to("bias_rw_rad_s_sqrt_s"),
            "star_sigma_arcsec": ws.Sigma(ws.positive(36_000.0), scale=ARCSEC)
            .to("star_sigma_rad"),
            **wc.settings_tables(),
        },
        into=AttitudeFilterSpec,
    ),
    "scoring": ws.Section(
        {
            "steady_state_from_s": ws.Number(ws.Interval(0.0, 86_400.0)),
            "report_convergence": ws.Boolean(default=False),
            "divergence_deg": wc.divergence(1.0),
        },
        into=ScoringSpec,
    ),
}, paper=PAPER)
SCHEMA = WORLD.schema


RULES = (
    wc.divides_rate("star_sensor.rate_hz", "gyro.rate_hz", "gyro"),
    wc.whole_periods_of("star_sensor.rate_hz", "star-sensor"),
    wc.below("scoring.steady_state_from_s", "duration_s"),
)
"""Checks across keys, in the order they are made."""


def _directions(star: dict[str, Any], at: ws.Where) -> tuple[tuple[float, float, float], ...]:
    """The reference star directions: the file's, or the first ``n_stars`` defaults."""
    dirs = star["directions"]
    if dirs is None:
        raw = np.array(DEFAULT_STAR_DIRECTIONS[: star["n_stars"]], dtype=float)
        dirs = tuple(tuple(float(c) for c in r / np.linalg.norm(r)) for r in raw)
    elif len(dirs) != star["n_stars"]:
        raise at.error(f"must list n_stars = {star['n_stars']} directions",
                       [list(d) for d in dirs])
    if star["mode"] == "vectors" and np.linalg.matrix_rank(np.array(dirs), tol=1e-3) < 2:
        raise at.error("must hold at least two non-parallel directions", [list(x) for x in dirs])
    return dirs


STATE_DIM, NOISE_DIM = 7, 6
"""The filters' state ``[q_nb, b]`` (ambient 7, :mod:`slam.kinds.attitude.run`) and its
process-noise inputs (angle random walk and bias random walk, 3 each)."""


def work(w: AttitudeWorld) -> Iterator[limits.Size]:
    """Gyro samples, star epochs, state and filter work of a run (:mod:`worlds.limits`)."""
    return wc.rate_work(w.duration_s, ("gyro.rate_hz", "gyro samples", w.gyro.rate_hz),
                        ("star_sensor.rate_hz", "star epochs", w.star.rate_hz),
                        STATE_DIM, NOISE_DIM)


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None
          ) -> AttitudeWorld:
    """Validate a parsed ``attitude`` TOML document and build its :class:`AttitudeWorld`."""
    root = ws.Where(source, "")
    v = ws.read_table(data, SCHEMA, root)
    ws.check_rules(RULES, v, root)
    wc.check_settings(v["filters"], v["filters"]["names"], root.child("filters"))
    dirs = _directions(v["star_sensor"], root.child("star_sensor.directions"))
    return ws.build(WORLD, v, name=name, source=source,
                    star=ws.build(SCHEMA["star_sensor"], v["star_sensor"], directions=dirs))
