"""The ``alignment`` world: initial alignment of a missile-borne SINS on a swaying
launcher under wind ([Wu-Wang 2014] §4).

Units are spelled in every key and converted to SI (radians, m/s², rad/s) on load.
File layout::

    kind = "alignment"
    description = "one line"
    runs = 50                       # Monte Carlo runs
    seed = 0                        # optional
    duration_s = 200.0
    [site]     latitude_deg, longitude_deg, height_m
    [sway]     heading_deg, elevation_deg, elevation_amplitude_deg, elevation_frequency_hz,
               roll_deg, roll_amplitude_deg, roll_frequency_hz, random_phases
    [wind]     mean_mps = [x, y], amplitude_x_mps = [3], amplitude_y_mps = [3],
               frequency_hz = [3], phase_rad = [3], compliance_m_per_mps
    [imu]      rate_hz, gyro_bias_deg_s, gyro_white_deg_s, gyro_markov_deg_s,
               gyro_markov_tau_s, accel_bias_g, accel_white_g, accel_markov_g,
               accel_markov_tau_s
    [filters]  names, rate_hz, velocity_sigma_mps, initial_misalignment_deg,
               initial_sigma_deg
    [filters.unscented] alpha, beta, kappa (ukf, uthinf)
    [filters.hinf]      gamma, on_failure (uthinf, srchinf)
    [sweep]    gammas, filters, runs (optional: the H∞ γ sweep)
    [reference] key_interval_s, position_sigma_m, runs
    [scoring]  settle_factor, divergence_deg
    [paper]    free-form: the paper's claims, passed through to summary.json
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterator
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from typing import Any

import worlds.common as wc
import worlds.schema as ws
from estimators.filters import FILTER_NAMES, ROBUST_FILTER_NAMES
from estimators.hinf import MIN_GAMMA
from nav.strapdown import G0
from worlds import limits
from worlds.units import DEG

KIND = "alignment"
NAMES = tuple(n for n in FILTER_NAMES + ROBUST_FILTER_NAMES if n != "hommukf")
"""Every filter but ``hommukf``: its Julier set (κ = 3 - n, centre weight 1 - 13/3) gives
an indefinite covariance at the first prediction through the normalised rotation
R(Q/|Q|) of the AQE model (:mod:`slam.kinds.alignment.models`), a rational map of δQ."""
HINF_NAMES = ROBUST_FILTER_NAMES
"""The H∞ filters a γ sweep runs."""


@dataclass(frozen=True)
class SwaySpec:
    """Launcher sway: elevation (nose up) and roll, each ``mean + A sin(2π f t + φ)``;
    heading fixed (from East, counter-clockwise); phases uniform per run if
    ``random_phases``."""

    heading_rad: float
    elevation_rad: float
    elevation_amplitude_rad: float
    elevation_frequency_hz: float
    roll_rad: float
    roll_amplitude_rad: float
    roll_frequency_hz: float
    random_phases: bool


@dataclass(frozen=True)
class WindSpec:
    """[Wu-Wang 2014] eq. 13: wind speed ``w_x,y(t) = mean + Σ_i a_i sin(2π f_i t + φ_i)``
    (m/s, x East, y North); the launcher deflects by ``compliance`` × (w − mean) (m)."""

    mean_mps: tuple[float, float]
    amplitude_x_mps: tuple[float, float, float]
    amplitude_y_mps: tuple[float, float, float]
    frequency_hz: tuple[float, float, float]
    phase_rad: tuple[float, float, float]
    compliance_m_per_mps: float


@dataclass(frozen=True)
class ImuSpec(wc.Sampled):
    """IMU at ``rate_hz``; per axis: random constant (σ), first-order Markov (stationary
    σ, correlation time) and white noise (σ per sample); SI units."""

    rate_hz: float
    gyro_bias_rad_s: float
    gyro_white_rad_s: float
    gyro_markov_rad_s: float
    gyro_markov_tau_s: float
    accel_bias_mps2: float
    accel_white_mps2: float
    accel_markov_mps2: float
    accel_markov_tau_s: float


@dataclass(frozen=True)
class AlignFilterSpec(wc.JointOnly, wc.TunedFilters):
    """Filters, their rate, the zero-velocity reference's σ and the initial misalignment
    (East, North, Up rotation vector of the SINS's error) with the prior σ; the settings
    tables (``[filters.unscented]``, ``[filters.hinf]``: :class:`worlds.common.TunedFilters`)."""

    names: tuple[str, ...]
    rate_hz: float
    velocity_sigma_mps: float
    initial_misalignment_rad: tuple[float, float, float]
    initial_sigma_rad: tuple[float, float, float]

    @property
    def gamma(self) -> float | None:
        """The stated H∞ bound (``None`` when no H∞ filter runs and none is stated)."""
        return (self.hinf or {}).get("gamma")


@dataclass(frozen=True)
class SweepSpec:
    """The H∞ γ sweep: each of ``filters`` at every bound in ``gammas`` on the first
    ``runs`` runs' logs, with ``on_failure = "kalman"`` (an update whose Riccati existence
    condition fails is the Kalman update for that step, counted)."""

    gammas: tuple[float, ...] = ()
    filters: tuple[str, ...] = ()
    runs: int = 0


@dataclass(frozen=True)
class ReferenceSpec:
    """GTSAM smoother: one NavState + bias key every ``key_interval_s``; the fixed
    position's σ; it runs on the first ``runs`` Monte Carlo runs (its 1 kHz
    preintegration costs about as much as two filters)."""

    key_interval_s: float
    position_sigma_m: float
    runs: int


@dataclass(frozen=True)
class ScoringSpec:
    """Settling: the error stays within ``settle_factor`` × its final value; a run whose
    final misalignment error exceeds ``divergence_rad`` counts as diverged; the ranking's
    per-run MSE is over the epochs from ``settled_from_s`` on (the paper's "settled
    within 50 s")."""

    settle_factor: float
    divergence_rad: float
    settled_from_s: float = 50.0


@dataclass(frozen=True)
class AlignmentWorld(wc.WorldBase):
    """A validated alignment world."""

    duration_s: float
    site: ws.SiteSpec
    sway: SwaySpec
    wind: WindSpec
    imu: ImuSpec
    filters: AlignFilterSpec
    reference: ReferenceSpec
    scoring: ScoringSpec
    sweep: SweepSpec = SweepSpec()

    samples_per_epoch = wc.per_epoch("imu", "filters", "IMU samples per filter interval")
    n_epochs = wc.epoch_count("filters", "filter epochs, the first at t = 0")
    epochs_per_key = property(lambda self: round(self.reference.key_interval_s
                                                 * self.filters.rate_hz),
                              doc="filter epochs per smoother key")


SMALL = ws.Interval(0.0, 45.0)
FREQ = ws.positive(100.0)
WIND = ws.Interval(0.0, 50.0)

PAPER = {"claims.ukf.east": ws.TEXT,
         **{f"claims.uthinf.{k}": ws.REAL
            for k in ("east_final_arcmin", "north_final_arcmin", "settle_within_s")}}
"""The ``[paper]`` keys the report reads (the UT-H∞ and UKF claims)."""

WORLD = wc.world(KIND, AlignmentWorld, {
    "duration_s": ws.Number(ws.positive(3600.0)),
    "site": ws.site(85.0, ws.Interval(-500.0, 9000.0), 0.0),
    "sway": ws.Section({
        "heading_deg": ws.Number(ws.Interval(-180.0, 180.0), scale=DEG).to("heading_rad"),
        "elevation_deg": ws.Number(ws.Interval(-80.0, 80.0), scale=DEG).to("elevation_rad"),
        "elevation_amplitude_deg": ws.Number(SMALL, scale=DEG).to("elevation_amplitude_rad"),
        "elevation_frequency_hz": ws.Number(FREQ),
        "roll_deg": ws.Number(ws.Interval(-90.0, 90.0), scale=DEG).to("roll_rad"),
        "roll_amplitude_deg": ws.Number(SMALL, scale=DEG).to("roll_amplitude_rad"),
        "roll_frequency_hz": ws.Number(FREQ),
        "random_phases": ws.Boolean(default=True),
    }, into=SwaySpec),
    "wind": ws.Section({
        "mean_mps": ws.Vector(2, WIND),
        "amplitude_x_mps": ws.Vector(3, WIND),
        "amplitude_y_mps": ws.Vector(3, WIND),
        "frequency_hz": ws.Vector(3, ws.positive(50.0)),
        "phase_rad": ws.Vector(3, ws.Interval(-10.0, 10.0)),
        "compliance_m_per_mps": ws.Number(ws.Interval(0.0, 1.0)),
    }, into=WindSpec),
    "imu": ws.Section({
        "rate_hz": ws.Number(ws.Interval(10.0, 10_000.0)),
        "gyro_bias_deg_s": wc.nonnegative(10.0, DEG, "gyro_bias_rad_s"),
        "gyro_white_deg_s": wc.nonnegative(10.0, DEG, "gyro_white_rad_s"),
        "gyro_markov_deg_s": wc.nonnegative(10.0, DEG, "gyro_markov_rad_s"),
        "gyro_markov_tau_s": ws.Number(ws.positive(1e6)),
        "accel_bias_g": wc.nonnegative(0.1, G0, "accel_bias_mps2"),
        "accel_white_g": wc.nonnegative(0.1, G0, "accel_white_mps2"),
        "accel_markov_g": wc.nonnegative(0.1, G0, "accel_markov_mps2"),
        "accel_markov_tau_s": ws.Number(ws.positive(1e6)),
    }, into=ImuSpec),
    "filters": ws.Section({
        "names": ws.StringList(NAMES),
        "rate_hz": ws.Number(ws.Interval(0.1, 1000.0)),
        "velocity_sigma_mps": ws.Sigma(ws.positive(10.0)),
        "initial_misalignment_deg": ws.Vector(3, ws.Interval(-60.0, 60.0), scale=DEG)
        .to("initial_misalignment_rad"),
        "initial_sigma_deg": wc.attitude_sigma("initial_sigma_rad", 60.0),
        **wc.settings_tables(),
    }, into=AlignFilterSpec),
    "reference": ws.Section({
        "key_interval_s": ws.Number(ws.positive(100.0), default=1.0),
        "position_sigma_m": ws.Sigma(ws.positive(100.0), default=0.01),
        "runs": ws.Integer(ws.Interval(0, 100_000), default=100_000),
    }, into=ReferenceSpec),
    "scoring": ws.Section({
        "settle_factor": ws.Number(ws.Interval(1.0, 10.0), default=1.2),
        "divergence_deg": wc.divergence(20.0),
        "settled_from_s": ws.Number(ws.Interval(0.0, 3600.0), default=50.0),
    }, into=ScoringSpec),
    "sweep": ws.Section({
        "gammas": ws.NumberList(ws.Interval(MIN_GAMMA, math.inf), max_len=20, default=tuple),
        "filters": ws.StringList(HINF_NAMES, default=tuple),
        "runs": ws.Integer(ws.Interval(0, 100_000), default=0),
    }, required=False, into=SweepSpec),
}, paper=PAPER)
SCHEMA = WORLD.schema


RULES = (
    wc.divides_rate("filters.rate_hz", "imu.rate_hz", "IMU"),
    wc.whole_periods_of("filters.rate_hz", "filter"),
    ws.Rule("reference.key_interval_s", "duration_s", operator.le,
            "must not exceed {other} ({limit:g})"),
    wc.whole_periods_of("filters.rate_hz", "filter", key="reference.key_interval_s"),
    ws.Rule("reference.key_interval_s", "duration_s", ws.whole_times,
            "must divide {other} ({limit:g}) a whole number of times"),
    wc.below("scoring.settled_from_s", "duration_s"),
)
"""Checks across keys, in the order they are made; the smoother's keys fall on filter
epochs and divide the run (the last two)."""


STATE_DIM = 13
"""The AQE filter state (:data:`slam.kinds.alignment.models.N_STATE`); its process noise
is additive over the whole state."""


def work(w: AlignmentWorld) -> Iterator[limits.Size]:
    """IMU samples, filter epochs, state and filter work of a run (:mod:`worlds.limits`);
    the GTSAM smoother preintegrates the same samples between keys on filter epochs."""
    return wc.rate_work(w.duration_s, ("imu.rate_hz", "IMU samples", w.imu.rate_hz),
                        ("filters.rate_hz", "filter epochs", w.filters.rate_hz),
                        STATE_DIM, STATE_DIM)


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None
          ) -> AlignmentWorld:
    """Validate a parsed ``alignment`` TOML document and build its :class:`AlignmentWorld`:
    every filter listed (and the sweep's) must find its settings table stated."""
    root = ws.Where(source, "")
    v = ws.read_table(data, SCHEMA, root)
    ws.check_rules(RULES, v, root)
    sweep = v.get("sweep") or {}
    wc.check_settings(v["filters"], list(v["filters"]["names"]) + list(sweep.get("filters", ())),
                      root.child("filters"))
    return ws.build(WORLD, v, name=name, source=source)
