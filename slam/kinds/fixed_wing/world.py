"""The ``fixed-wing`` world: a fixed-wing UAV's attitude from an Euler-angle filter with
accelerometer + magnetometer (EA) and from an INS/unit-quaternion filter with GNSS (INS)
([Fixed-wing EA-UKF] §5-6, Table 1).

Units are spelled in every key and converted to SI radians on load.  File layout::

    kind = "fixed-wing"
    description = "one line"
    runs = 15                        # Monte Carlo runs (the paper's fifteen)
    seed = 0
    duration_s = 500.0
    [site]        latitude_deg, longitude_deg, height_m (start of the flight)
    [flight]      start_speed_mps, start_heading_deg (from East, counter-clockwise),
                  start_climb_deg, manoeuvre_start_s, manoeuvre_ramp_s and the targets
                  each manoeuvre ramps to: turn_rate_deg_s, climb_deg, speed_mps
    [imu]         rate_hz, earth_rate, gyro_bias_sigma_deg_h, gyro_drift_rw_deg_h_sqrt_h,
                  gyro_drift_time_s, gyro_arw_deg_sqrt_h, accel_drift_sigma_mg,
                  accel_drift_rw_mg_sqrt_h, accel_drift_time_s, accel_vrw_mps_sqrt_h
    [magnetometer] field_ut, declination_deg, inclination_deg, sigma_ut
    [gnss]        rate_hz, horizontal_sigma_m, vertical_sigma_m, velocity_sigma_mps
    [ea]          update_rate_hz, roll_pitch_sigma_deg, heading_sigma_deg (what the EA
                  filters assume of the accelerometer / magnetometer angles),
                  initial_sigma_deg, initial_bias_sigma_deg_h
    [ins]         initial_attitude_sigma_deg, initial_velocity_sigma_mps,
                  initial_position_sigma_m
    [filters]     names ("ea-<filter>" / "ins-<filter>")
    [filters.unscented] alpha, beta, kappa (ea-ukf, ins-ukf)
    [scoring]     turn_rate_deg_s (a turn: |heading rate| above it), accel_mps2 (an
                  accelerating epoch outside turns), divergence_deg
    [paper]       free-form: the paper's Table 1, passed through to summary.json
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from typing import Any

import numpy as np

import worlds.common as wc
import worlds.schema as ws
from worlds import limits
from worlds.units import DEG, DEG_H, DEG_H_SQRT_H, DEG_SQRT_H, MG, MG_SQRT_H, MPS_SQRT_H

KIND = "fixed-wing"

EA_FILTERS = ("ukf", "ckf", "srckf", "ekf")
INS_FILTERS = ("ckf", "ukf", "srckf", "ekf")
FILTERS = tuple(f"ea-{n}" for n in EA_FILTERS) + tuple(f"ins-{n}" for n in INS_FILTERS)
"""Every estimator name a fixed-wing world can run: ``ea-*`` on the Euler-angle model,
``ins-*`` on the INS/unit-quaternion model."""


@dataclass(frozen=True)
class FlightSpec:
    """The smooth flight: start state and manoeuvres; manoeuvre ``i`` ramps turn rate,
    flight-path angle and speed from their previous values to its targets over
    ``ramp_s[i]`` seconds from ``start_s[i]`` (radians, rad/s, m/s)."""

    start_speed_mps: float
    start_heading_rad: float
    start_climb_rad: float
    start_s: tuple[float, ...]
    ramp_s: tuple[float, ...]
    turn_rate_rad_s: tuple[float, ...]
    climb_rad: tuple[float, ...]
    speed_mps: tuple[float, ...]


@dataclass(frozen=True)
class ImuSpec(wc.Sampled):
    """MEMS IMU (SI): gyro constant drift σ (drawn per run), first-order Markov gyro
    drift (driving density, correlation time), white noise; accelerometer Markov drift
    (initial σ, driving density, correlation time) and white noise."""

    rate_hz: float
    earth_rate: bool
    gyro_bias_sigma_rad_s: float
    gyro_drift_rw_rad_s_sqrt_s: float
    gyro_drift_time_s: float
    gyro_arw_rad_sqrt_s: float
    accel_drift_sigma_mps2: float
    accel_drift_rw_mps2_sqrt_s: float
    accel_drift_time_s: float
    accel_vrw_mps_sqrt_s: float


@dataclass(frozen=True)
class MagSpec:
    """Geomagnetic field (µT, radians) and the magnetometer's white noise per axis (µT)."""

    field_ut: float
    declination_rad: float
    inclination_rad: float
    sigma_ut: float


@dataclass(frozen=True)
class GnssSpec:
    """GNSS position (m) and velocity (m/s) fixes, white noise per axis."""

    rate_hz: float
    horizontal_sigma_m: float
    vertical_sigma_m: float
    velocity_sigma_mps: float


@dataclass(frozen=True)
class EaSpec:
    """The Euler-angle filters: update rate and assumed measurement σ (rad), initial σ."""

    update_rate_hz: float
    roll_pitch_sigma_rad: float
    heading_sigma_rad: float
    initial_sigma_rad: tuple[float, float, float]
    initial_bias_sigma_rad_s: float


@dataclass(frozen=True)
class InsSpec:
    """The INS filters' initial σ (rad, m/s, m); drift σ come from ``[imu]``."""

    initial_attitude_sigma_rad: tuple[float, float, float]
    initial_velocity_sigma_mps: float
    initial_position_sigma_m: float


@dataclass(frozen=True)
class FilterSpec(wc.JointOnly, wc.TunedFilters):
    """The estimators to run and their settings tables (``[filters.unscented]`` for
    ``ea-ukf`` / ``ins-ukf``: :class:`worlds.common.TunedFilters`)."""

    names: tuple[str, ...]


@dataclass(frozen=True)
class ScoringSpec:
    """A turn is an epoch whose true heading rate exceeds ``turn_rate_rad_s``; an
    accelerating epoch one outside turns whose true acceleration exceeds ``accel_mps2``
    (speed changes, pull-ups); a run whose final attitude error exceeds ``divergence_rad``
    counts as diverged."""

    turn_rate_rad_s: float
    accel_mps2: float
    divergence_rad: float


@dataclass(frozen=True)
class FixedWingWorld(wc.WorldBase):
    """A validated fixed-wing world."""

    duration_s: float
    site: ws.SiteSpec
    flight: FlightSpec
    imu: ImuSpec
    magnetometer: MagSpec
    gnss: GnssSpec
    ea: EaSpec
    ins: InsSpec
    filters: FilterSpec
    scoring: ScoringSpec

    @property
    def n_samples(self) -> int:
        """IMU intervals of the flight."""
        return round(self.duration_s * self.imu.rate_hz)


SPEED = ws.Interval(5.0, 100.0)
PAPER = {f"table1.*.{k}": ws.REAL for k in ("longitude_m", "latitude_m", "east_velocity_mps",
                                          "north_velocity_mps", "heading_deg")}
"""The ``[paper]`` keys the report reads (Table 1's mean errors per filter)."""

WORLD = wc.world(KIND, FixedWingWorld, {
    "duration_s": ws.Number(ws.positive(7_200.0)),
    "site": ws.site(80.0, ws.Interval(-400.0, 10_000.0)),
    "flight": ws.Section({
        "start_speed_mps": ws.Number(SPEED),
        "start_heading_deg": ws.Number(ws.Interval(-180.0, 180.0), scale=DEG)
        .to("start_heading_rad"),
        "start_climb_deg": ws.Number(ws.Interval(-30.0, 30.0), scale=DEG).to("start_climb_rad"),
        "manoeuvre_start_s": ws.NumberList(ws.Interval(0.0, 7_200.0)).to("start_s"),
        "manoeuvre_ramp_s": ws.NumberList(ws.Interval(0.5, 600.0)).to("ramp_s"),
        "turn_rate_deg_s": ws.NumberList(ws.Interval(-30.0, 30.0), scale=DEG).to("turn_rate_rad_s"),
        "climb_deg": ws.NumberList(ws.Interval(-30.0, 30.0), scale=DEG).to("climb_rad"),
        "speed_mps": ws.NumberList(SPEED),
    }, into=FlightSpec),
    "imu": ws.Section({
        "rate_hz": ws.Number(ws.Interval(10.0, 1_000.0)),
        "earth_rate": ws.Boolean(default=True),
        "gyro_bias_sigma_deg_h": wc.nonnegative(3_600.0, DEG_H, "gyro_bias_sigma_rad_s"),
        "gyro_drift_rw_deg_h_sqrt_h": wc.nonnegative(1_000.0, DEG_H_SQRT_H,
                                                  "gyro_drift_rw_rad_s_sqrt_s"),
        "gyro_drift_time_s": ws.Number(ws.Interval(1.0, 1e6)),
        "gyro_arw_deg_sqrt_h": wc.nonnegative(100.0, DEG_SQRT_H, "gyro_arw_rad_sqrt_s"),
        "accel_drift_sigma_mg": wc.nonnegative(100.0, MG, "accel_drift_sigma_mps2"),
        "accel_drift_rw_mg_sqrt_h": wc.nonnegative(100.0, MG_SQRT_H, "accel_drift_rw_mps2_sqrt_s"),
        "accel_drift_time_s": ws.Number(ws.Interval(1.0, 1e6)),
        "accel_vrw_mps_sqrt_h": wc.nonnegative(100.0, MPS_SQRT_H, "accel_vrw_mps_sqrt_s"),
    }, into=ImuSpec),
    "magnetometer": ws.Section({
        "field_ut": ws.Number(ws.Interval(10.0, 100.0)),
        "declination_deg": ws.Number(ws.Interval(-180.0, 180.0), scale=DEG)
        .to("declination_rad"),
        "inclination_deg": ws.Number(ws.Interval(-85.0, 85.0), scale=DEG).to("inclination_rad"),
        "sigma_ut": ws.Sigma(ws.Interval(0.0, 50.0)),
    }, into=MagSpec),
    "gnss": ws.Section({
        "rate_hz": ws.Number(ws.Interval(0.01, 100.0)),
        "horizontal_sigma_m": ws.Sigma(ws.positive(1_000.0)),
        "vertical_sigma_m": ws.Sigma(ws.positive(1_000.0)),
        "velocity_sigma_mps": ws.Sigma(ws.positive(100.0)),
    }, into=GnssSpec),
    "ea": ws.Section({
        "update_rate_hz": ws.Number(ws.Interval(0.1, 1_000.0)),
        "roll_pitch_sigma_deg": ws.Sigma(ws.positive(90.0), scale=DEG).to("roll_pitch_sigma_rad"),
        "heading_sigma_deg": ws.Sigma(ws.positive(90.0), scale=DEG).to("heading_sigma_rad"),
        "initial_sigma_deg": wc.attitude_sigma("initial_sigma_rad"),
        "initial_bias_sigma_deg_h": wc.bias_sigma(36_000.0),
    }, into=EaSpec),
    "ins": ws.Section({
        "initial_attitude_sigma_deg": wc.attitude_sigma("initial_attitude_sigma_rad"),
        "initial_velocity_sigma_mps": ws.Sigma(ws.positive(100.0)),
        "initial_position_sigma_m": ws.Sigma(ws.positive(1_000.0)),
    }, into=InsSpec),
    "filters": ws.Section({"names": ws.StringList(FILTERS), **wc.settings_tables()},
                          into=FilterSpec),
    "scoring": ws.Section({
        "turn_rate_deg_s": ws.Number(ws.positive(30.0), default=1.0, scale=DEG)
        .to("turn_rate_rad_s"),
        "accel_mps2": ws.Number(ws.positive(10.0), default=0.05),
        "divergence_deg": wc.divergence(45.0),
    }, into=ScoringSpec),
}, paper=PAPER)
SCHEMA = WORLD.schema


RULES = (
    wc.divides_rate("gnss.rate_hz", "imu.rate_hz", "IMU"),
    wc.divides_rate("ea.update_rate_hz", "imu.rate_hz", "IMU"),
    ws.Rule("duration_s", "gnss.rate_hz", lambda d, r: ws.is_whole(d * r) and d * r >= 2,
            lambda r: f"must be a whole number (>= 2) of GNSS periods ({1 / r:g} s)"),
    ws.Rule("duration_s", "ea.update_rate_hz", lambda d, r: ws.is_whole(d * r) and d * r >= 1,
            lambda r: f"must be a whole number of EA periods ({1 / r:g} s)"),
)


def _check_flight(v: dict[str, Any], root: ws.Where) -> None:
    """Manoeuvre lists of one length, in time order, not overlapping, inside the run."""
    fl, at = v["flight"], root.child("flight")
    n = len(fl["manoeuvre_start_s"])
    for key in ("manoeuvre_ramp_s", "turn_rate_deg_s", "climb_deg", "speed_mps"):
        if len(fl[key]) != n:
            raise at.child(key).error(f"must have as many entries as manoeuvre_start_s ({n})",
                                      len(fl[key]))
    start, ramp = np.array(fl["manoeuvre_start_s"]), np.array(fl["manoeuvre_ramp_s"])
    end = start + ramp
    for i in range(1, n):
        if start[i] < end[i - 1]:
            raise at.child("manoeuvre_start_s").item(i).error(
                f"must not start before manoeuvre {i - 1} ends ({end[i - 1]:g} s)", start[i])
    if end[-1] > v["duration_s"]:
        raise at.child("manoeuvre_ramp_s").item(n - 1).error(
            f"the last manoeuvre must end by duration_s ({v['duration_s']:g} s)", ramp[-1])


STATE_DIM, NOISE_DIM = 19, 18
"""The INS/UQ filters' state (ambient 19: position, velocity, quaternion, biases;
tangent 18, :data:`slam.kinds.fixed_wing.ins.DIM`) and its additive process noise; the
EA filters' 6-state is smaller."""


def work(w: FixedWingWorld) -> Iterator[limits.Size]:
    """IMU samples, filter epochs (EA updates or GNSS fixes, whichever are more), state
    and filter work of a run (:mod:`worlds.limits`)."""
    epochs = max(("ea.update_rate_hz", "EA filter epochs", w.ea.update_rate_hz),
                 ("gnss.rate_hz", "GNSS epochs", w.gnss.rate_hz), key=lambda e: e[2])
    return wc.rate_work(w.duration_s, ("imu.rate_hz", "IMU samples", w.imu.rate_hz), epochs,
                        STATE_DIM, NOISE_DIM)


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None
          ) -> FixedWingWorld:
    """Validate a parsed ``fixed-wing`` TOML document and build its world."""
    root = ws.Where(source, "")
    v = ws.read_table(data, SCHEMA, root)
    ws.check_rules(RULES, v, root)
    _check_flight(v, root)
    wc.check_settings(v["filters"], v["filters"]["names"], root.child("filters"))
    return ws.build(WORLD, v, name=name, source=source)
