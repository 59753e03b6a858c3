"""The ``ship`` world: ship SINS quaternion attitude from a fibre-optic gyro and vector
observations ([Ding 2017] §4, Table 1).

Units are spelled in every key and converted to SI radians on load; the dataclasses name
their SI units.  File layout::

    kind = "ship"
    description = "one line"
    runs = 50                       # Monte Carlo runs
    seed = 0                        # optional
    duration_s = 300.0
    [site]       latitude_deg, longitude_deg, height_m (the ship floats there, at rest)
    [waves]      heading_deg (mean heading, yaw from East counter-clockwise),
                 roll_amplitude_deg, roll_period_s, pitch_amplitude_deg, pitch_period_s,
                 yaw_amplitude_deg, yaw_period_s, random_phases
    [gyro]       rate_hz, arw_deg_sqrt_h, bias_rw_deg_h_sqrt_h, bias_deg_h = [x, y, z]
    [vectors]    rate_hz, gravity_sigma_mg, field_declination_deg, field_inclination_deg,
                 magnetometer_sigma_percent
    [filters]    names, paper_model (filters run on the paper's model), variants
                 ("filter:treatment" extra runs for the effects table), initial_error_deg,
                 initial_attitude_sigma_deg, initial_bias_sigma_deg_h; the settings
                 tables [filters.unscented], [filters.central_difference],
                 [filters.homm] (required by the filters that take them)
    [scoring]    converge_arcmin, steady_state_from_s, divergence_deg
    [paper]      free-form: the paper's claims, passed through to summary.json

The filters and the smoother assume the noises the simulation draws (the gyro's and the
vector sensors'); see :mod:`slam.kinds.ship.simulate` for the motion and the sensors and
:mod:`slam.kinds.ship.models` for the treatments.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from typing import Any

import worlds.common as wc
import worlds.schema as ws
from estimators.filters import FILTER_NAMES
from worlds import limits
from worlds.units import DEG, DEG_H, DEG_H_SQRT_H, DEG_SQRT_H

KIND = "ship"
MG = 1e-3  # milli-g -> fraction of g
PERCENT = 1e-2

#: How a filter treats the quaternion (see :mod:`slam.kinds.ship.models`):
#: ``paper`` - pseudo-observation Z = G q with the noise-separation covariance and the
#: eigenvector (Lagrange) mean; ``additive`` - the same measurement, the renormalised
#: weighted sum of the quaternions as the mean; ``chart`` - the same measurement, the
#: iterative q ⊗ Exp(δ) chart mean; ``manifold`` - the plain vector measurement
#: B = C(q)ᵀ R with the chart mean (the MEKF / SRCKF treatment).
TREATMENTS = ("paper", "additive", "chart", "manifold")


class Variants(ws.Field):
    """A list of ``"filter:treatment"`` strings -> tuple of ``(filter, treatment)`` pairs."""

    def __init__(self, default: Any = ws.REQUIRED) -> None:
        self.default = default

    def parse(self, value: Any, where: ws.Where) -> tuple[tuple[str, str], ...]:
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise where.error('must be a list of "filter:treatment" strings', value)
        out = []
        for i, v in enumerate(value):
            name, _, treatment = v.partition(":")
            if name not in FILTER_NAMES:
                raise where.item(i).error(f"unknown filter; allowed: {', '.join(FILTER_NAMES)}",
                                          v)
            if treatment not in TREATMENTS:
                raise where.item(i).error(f"unknown treatment; allowed: {', '.join(TREATMENTS)}",
                                          v)
            out.append((name, treatment))
        if len(set(out)) != len(out):
            raise where.error("must not repeat a variant", value)
        return tuple(out)


@dataclass(frozen=True)
class WaveSpec:
    """Wave-induced attitude motion: ``angle(t) = A sin(2π t / T + φ)`` per axis, yaw about
    ``heading_rad``; phases uniform per run when ``random_phases`` (else zero)."""

    heading_rad: float
    roll_amplitude_rad: float
    roll_period_s: float
    pitch_amplitude_rad: float
    pitch_period_s: float
    yaw_amplitude_rad: float
    yaw_period_s: float
    random_phases: bool


@dataclass(frozen=True)
class GyroSpec(wc.Sampled):
    """Fibre-optic gyro: ``ω̃ = ω_ib + b(t) + n``; ``bias_rad_s`` is b(0)."""

    rate_hz: float
    arw_rad_sqrt_s: float
    bias_rw_rad_s_sqrt_s: float
    bias_rad_s: tuple[float, float, float]


@dataclass(frozen=True)
class VectorSpec:
    """Vector observations ``B_j = C(q)ᵀ R_j + μ_j`` at ``rate_hz``: gravity (unit
    reference, noise as a fraction of g) and the geomagnetic field direction (unit
    reference, noise as a fraction of the field's magnitude), σ per body axis."""

    rate_hz: float
    gravity_sigma: float
    field_declination_rad: float
    field_inclination_rad: float
    magnetometer_sigma: float


@dataclass(frozen=True)
class ShipFilterSpec(wc.TunedFilters, wc.JointOnly):
    """Filters, their treatments, their settings tables and the initial belief (radians,
    rad/s)."""

    names: tuple[str, ...]
    paper_model: tuple[str, ...]
    variants: tuple[tuple[str, str], ...]
    initial_error_rad: tuple[float, float, float]
    initial_attitude_sigma_rad: tuple[float, float, float]
    initial_bias_sigma_rad_s: float

    def treatment(self, name: str) -> str:
        """The treatment of main filter ``name``: ``paper`` or ``manifold``."""
        return "paper" if name in self.paper_model else "manifold"


@dataclass(frozen=True)
class ScoringSpec:
    """``converge_rad``: the roll/pitch bound of the time-to-converge score (10′);
    ``steady_state_from_s``: start of the steady-state window; a run whose final attitude
    error exceeds ``divergence_rad`` counts as diverged."""

    converge_rad: float
    steady_state_from_s: float
    divergence_rad: float


@dataclass(frozen=True)
class ShipWorld(wc.WorldBase):
    """A validated ship world."""

    duration_s: float
    site: ws.SiteSpec
    waves: WaveSpec
    gyro: GyroSpec
    vectors: VectorSpec
    filters: ShipFilterSpec
    scoring: ScoringSpec

    samples_per_update = wc.per_epoch("gyro", "vectors",
                                      "gyro samples per vector-observation interval")
    n_updates = wc.epoch_count("vectors", "vector-observation epochs, the first at t = 0")


ANGLE = ws.Interval(0.0, 45.0)
PERIOD = ws.Interval(0.5, 600.0)

PAPER = {"note": ws.TEXT, "claims.*.roll_pitch_within_arcmin": ws.REAL,
         "claims.*.yaw_within_arcmin": ws.REAL, "claims.*.yaw": ws.TEXT}
"""The ``[paper]`` keys the report reads (each filter's claims)."""

WORLD = wc.world(KIND, ShipWorld, {
    "duration_s": ws.Number(ws.positive(86_400.0)),
    "site": ws.site(89.0, ws.Interval(-100.0, 100.0), 0.0),
    "waves": ws.Section({
        "heading_deg": ws.Number(ws.Interval(-180.0, 180.0), scale=DEG).to("heading_rad"),
        "roll_amplitude_deg": ws.Number(ANGLE, scale=DEG).to("roll_amplitude_rad"),
        "roll_period_s": ws.Number(PERIOD),
        "pitch_amplitude_deg": ws.Number(ANGLE, scale=DEG).to("pitch_amplitude_rad"),
        "pitch_period_s": ws.Number(PERIOD),
        "yaw_amplitude_deg": ws.Number(ANGLE, scale=DEG).to("yaw_amplitude_rad"),
        "yaw_period_s": ws.Number(PERIOD),
        "random_phases": ws.Boolean(default=True),
    }, into=WaveSpec),
    "gyro": ws.Section({
        "rate_hz": ws.Number(ws.positive(10_000.0)),
        "arw_deg_sqrt_h": wc.nonnegative(100.0, DEG_SQRT_H, "arw_rad_sqrt_s"),
        "bias_rw_deg_h_sqrt_h": wc.nonnegative(100.0, DEG_H_SQRT_H, "bias_rw_rad_s_sqrt_s"),
        "bias_deg_h": ws.Vector(3, ws.Interval(-3600.0, 3600.0), scale=DEG_H).to("bias_rad_s"),
    }, into=GyroSpec),
    "vectors": ws.Section({
        "rate_hz": ws.Number(ws.positive(100.0)),
        "gravity_sigma_mg": ws.Sigma(ws.positive(500.0), scale=MG).to("gravity_sigma"),
        "field_declination_deg": ws.Number(ws.Interval(-180.0, 180.0), scale=DEG)
        .to("field_declination_rad"),
        "field_inclination_deg": ws.Number(ws.Interval(-85.0, 85.0), scale=DEG)
        .to("field_inclination_rad"),
        "magnetometer_sigma_percent": ws.Sigma(ws.positive(50.0), scale=PERCENT)
        .to("magnetometer_sigma"),
    }, into=VectorSpec),
    "filters": ws.Section({
        "names": ws.StringList(FILTER_NAMES),
        "paper_model": ws.StringList(FILTER_NAMES),
        "variants": Variants(default=[]),
        "initial_error_deg": ws.Vector(3, ws.Interval(-45.0, 45.0), scale=DEG)
        .to("initial_error_rad"),
        "initial_attitude_sigma_deg": wc.attitude_sigma("initial_attitude_sigma_rad"),
        "initial_bias_sigma_deg_h": wc.bias_sigma(3600.0),
        **wc.settings_tables(),
    }, into=ShipFilterSpec),
    "scoring": ws.Section({
        "converge_arcmin": ws.Number(ws.positive(600.0), default=10.0, scale=DEG / 60.0)
        .to("converge_rad"),
        "steady_state_from_s": ws.Number(ws.Interval(0.0, 86_400.0)),
        "divergence_deg": wc.divergence(10.0),
    }, into=ScoringSpec),
}, paper=PAPER)
SCHEMA = WORLD.schema


def _subset(value: tuple[str, ...], names: tuple[str, ...]) -> bool:
    return set(value) <= set(names)


RULES = (
    wc.divides_rate("vectors.rate_hz", "gyro.rate_hz", "gyro"),
    wc.whole_periods_of("vectors.rate_hz", "vector"),
    wc.below("scoring.steady_state_from_s", "duration_s"),
    ws.Rule("filters.paper_model", "filters.names", _subset,
            "must name only filters listed in {other}"),
)
"""Checks across keys, in the order they are made."""


STATE_DIM, NOISE_DIM = 7, 6
"""The filters' state ``[q, b]`` (ambient 7, :mod:`slam.kinds.ship.models`) and its
process-noise inputs (angle random walk and drift random walk, 3 each)."""


def work(w: ShipWorld) -> Iterator[limits.Size]:
    """Gyro samples, vector epochs, state and filter work of a run (:mod:`worlds.limits`)."""
    return wc.rate_work(w.duration_s, ("gyro.rate_hz", "gyro samples", w.gyro.rate_hz),
                        ("vectors.rate_hz", "vector-observation epochs", w.vectors.rate_hz),
                        STATE_DIM, NOISE_DIM)


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None
          ) -> ShipWorld:
    """Validate a parsed ``ship`` TOML document and build its :class:`ShipWorld`; every
    settings table a listed filter or variant needs must be stated."""
    root = ws.Where(source, "")
    v = ws.read_table(data, SCHEMA, root)
    ws.check_rules(RULES, v, root)
    f = v["filters"]
    wc.check_settings(f, [*f["names"], *(f"{n}:{t}" for n, t in f["variants"])],
                      root.child("filters"))
    return ws.build(WORLD, v, name=name, source=source)
