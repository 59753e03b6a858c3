"""The ``spinning`` world: a high-spin projectile's pitch and yaw from a gyro and a
three-axis magnetometer ([Spin SR-CH∞KF], Tables 1-2).

Units are spelled in every key and converted to SI radians on load.  File layout::

    kind = "spinning"
    description = "one line"
    runs = 50                       # Monte Carlo runs
    seed = 0                        # optional
    sample_interval_s = 0.1         # gyro and magnetometer (Table 2)
    [launch]       speed_mps, pitch_deg, yaw_deg, roll_deg (Table 2)
    [flight]       scale_height_m, crosswind_mps, drag_k_per_m (optional: calibrated),
                   target_flight_time_s, target_range_m, target_apex_m (Table 2)
    [spin]         rate_rev_s, decay_time_s
    [field]        intensity_nt, inclination_deg, declination_deg (Table 1)
    [gyro]         rate_noise_deg_s_sqrt_hz (pitch/yaw rate noise density the filters
                   assume), roll_range_deg_s (the roll channel saturates above it)
    [magnetometer] noise_nt (per axis, per sample, what the filters assume)
    [truth_noise]  magnetometer_factor, gyro_factor (true noise = factor x assumed),
                   distribution ("gaussian" | "student-t" | "contaminated"),
                   student_t_dof, contamination_fraction, contamination_scale
    [filters]      names, initial_sigma_deg = [pitch, yaw]
    [filters.hinf] gamma (rad: the paper's kappa), on_failure ("kalman" | "raise"), for
                   srchinf / uthinf
    [filters.unscented] alpha, beta, kappa (for ukf / uthinf)
    [scoring]      blind_area_deg, divergence_deg
    [sweep]        factors, gammas_rad, distributions, runs_per_cell, filters,
                   scales (a list of "both" | "magnetometer" | "gyro": the sensors the
                   factor scales; one mismatch sweep per entry)
    [paper]        free-form: the paper's statements, passed through to summary.json
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from typing import Any

import worlds.common as wc
import worlds.schema as ws
from estimators.filters import FILTER_NAMES, ROBUST_FILTER_NAMES
from slam.kinds.spinning.noise import DISTRIBUTIONS, NoiseShape
from slam.kinds.spinning.truth import Field, FlightSpec, G
from worlds import limits

KIND = "spinning"
DEG = math.pi / 180.0
NAMES = FILTER_NAMES + ROBUST_FILTER_NAMES
SCALES = ("both", "magnetometer", "gyro")


class Gammas(ws.Field):
    """A non-empty list of H∞ bounds γ (rad): positive numbers, ``inf`` allowed (Kalman);
    γ² must not underflow (the filters use 1/γ², :func:`~worlds.schema.check_variance`)."""

    def __init__(self, default: Any = ws.REQUIRED) -> None:
        self.default = default

    def parse(self, value: Any, where: ws.Where) -> tuple[float, ...]:
        if not isinstance(value, list) or not value:
            raise where.error("must be a non-empty list of positive numbers (inf allowed)",
                              value)
        for i, v in enumerate(value):
            if not (isinstance(v, int | float) and not isinstance(v, bool) and v > 0.0):
                raise where.item(i).error("must be a positive number or inf", v)
            ws.check_variance(float(v), 2, ws.positive(math.inf), 1.0, where.item(i), v)
        return tuple(float(v) for v in value)


class Factors(ws.Field):
    """A non-empty list of noise factors in [1, 100]."""

    def __init__(self, default: Any = ws.REQUIRED) -> None:
        self.default = default

    def parse(self, value: Any, where: ws.Where) -> tuple[float, ...]:
        if not isinstance(value, list) or not value:
            raise where.error("must be a non-empty list of numbers in [1, 100]", value)
        for i, v in enumerate(value):
            if not (isinstance(v, int | float) and not isinstance(v, bool) and 1.0 <= v <= 100.0):
                raise where.item(i).error("must be a number in [1, 100]", v)
        return tuple(float(v) for v in value)


@dataclass(frozen=True)
class SpinSpec:
    """Roll spin: rate (rev/s) at launch and its e-folding decay time (s)."""

    rate_rev_s: float
    decay_time_s: float


@dataclass(frozen=True)
class GyroSpec:
    """Pitch/yaw rate noise density the filters assume (rad/s/√Hz; per sample
    σ = density/√dt) and the roll channel's range (rad/s)."""

    rate_noise_rad_s_sqrt_hz: float
    roll_range_rad_s: float


@dataclass(frozen=True)
class MagnetometerSpec:
    """Per-axis, per-sample noise the filters assume (nT)."""

    noise_nt: float


@dataclass(frozen=True)
class SpinningFilterSpec(wc.JointOnly, wc.TunedFilters):
    """Filters to run, the prior σ, and the settings tables (``[filters.hinf]``: γ in rad
    and the failure policy of ``srchinf``/``uthinf``; ``[filters.unscented]``)."""

    names: tuple[str, ...]
    initial_sigma_rad: tuple[float, float]

    @property
    def gamma_rad(self) -> float | None:
        """The H∞ bound γ of ``[filters.hinf]`` (``None`` when no H∞ filter is listed)."""
        return None if self.hinf is None else float(self.hinf["gamma"])

    @property
    def on_failure(self) -> str | None:
        """``[filters.hinf] on_failure`` (``None`` when no H∞ filter is listed)."""
        return None if self.hinf is None else str(self.hinf["on_failure"])


@dataclass(frozen=True)
class ScoringSpec:
    """``blind_area_rad``: the body axis closer than this to the field line is the blind
    area; a run whose final pitch or yaw error exceeds ``divergence_rad`` is diverged."""

    blind_area_rad: float
    divergence_rad: float


@dataclass(frozen=True)
class SweepSpec:
    """The noise-mismatch sweeps: true noise ``factor`` x assumed on the sensors each of
    ``scales`` names ("both": gyro and magnetometer together, which leaves the Kalman gain
    unchanged; "gyro" or "magnetometer" alone, which does not), per distribution, for every
    filter (H∞ filters at every γ), ``runs_per_cell`` logs per (scale, distribution,
    factor)."""

    factors: tuple[float, ...]
    gammas_rad: tuple[float, ...]
    distributions: tuple[str, ...]
    runs_per_cell: int
    filters: tuple[str, ...]
    scales: tuple[str, ...] = ("both",)

    @property
    def tasks(self) -> int:
        """Sweep logs in all: one per (replicate, scale, distribution, factor)."""
        return (self.runs_per_cell * len(self.scales) * len(self.distributions)
                * len(self.factors))


@dataclass(frozen=True)
class SpinningWorld(wc.WorldBase):
    """A validated ``spinning`` world (SI units, radians)."""

    sample_interval_s: float
    flight: FlightSpec
    roll0_rad: float
    spin: SpinSpec
    field: Field
    gyro: GyroSpec
    magnetometer: MagnetometerSpec
    truth_noise: NoiseShape
    filters: SpinningFilterSpec
    scoring: ScoringSpec
    sweep: SweepSpec


_LAUNCH = {
    "speed_mps": ws.Number(ws.positive(3000.0)),
    "pitch_deg": ws.Number(ws.Interval(1.0, 89.0), scale=DEG),
    "yaw_deg": ws.Number(ws.Interval(-180.0, 180.0), scale=DEG),
    "roll_deg": ws.Number(ws.Interval(-180.0, 180.0), scale=DEG),
}
_FLIGHT = {
    "scale_height_m": ws.Number(ws.positive(1e9), default=10_400.0),
    "crosswind_mps": ws.Number(ws.Interval(-50.0, 50.0), default=0.0),
    "drag_k_per_m": ws.Number(ws.Interval(0.0, 1e-2), default=None),
    "target_flight_time_s": ws.Number(ws.positive(1000.0)),
    "target_range_m": ws.Number(ws.positive(1e6)),
    "target_apex_m": ws.Number(ws.positive(1e6)),
}
PAPER = {k: ws.TEXT for k in ("best_pitch", "worst_pitch", "best_yaw", "worst_yaw",
                           "best_roll_blind", "blind_area")}
"""The ``[paper]`` keys the report reads (its figures' statements, shown as text)."""

WORLD = wc.world(KIND, SpinningWorld, {
    "sample_interval_s": ws.Number(ws.Interval(0.001, 1.0)),
    "launch": ws.Section(_LAUNCH, attr=None),
    "flight": ws.Section(_FLIGHT, attr=None),
    "spin": ws.Section({
        "rate_rev_s": ws.Number(ws.Interval(0.0, 500.0)),
        "decay_time_s": ws.Number(ws.positive(1e9)),
    }, into=SpinSpec),
    "field": ws.Section({
        "intensity_nt": ws.Number(ws.positive(1e6)),
        "inclination_deg": ws.Number(ws.Interval(-90.0, 90.0), scale=DEG).to("inclination_rad"),
        "declination_deg": ws.Number(ws.Interval(-180.0, 180.0), scale=DEG)
        .to("declination_rad"),
    }, into=Field),
    "gyro": ws.Section({
        "rate_noise_deg_s_sqrt_hz": ws.Sigma(ws.positive(100.0), scale=DEG)
        .to("rate_noise_rad_s_sqrt_hz"),
        "roll_range_deg_s": ws.Number(ws.positive(1e6), scale=DEG).to("roll_range_rad_s"),
    }, into=GyroSpec),
    "magnetometer": ws.Section({"noise_nt": ws.Sigma(ws.positive(1e5))},
                               into=MagnetometerSpec),
    "truth_noise": ws.Section({
        "magnetometer_factor": ws.Sigma(ws.Interval(0.0, 100.0), default=1.0),
        "gyro_factor": ws.Sigma(ws.Interval(0.0, 100.0), default=1.0),
        "distribution": ws.String(choices=DISTRIBUTIONS, default="gaussian"),
        "student_t_dof": ws.Number(ws.Interval(2.0, 1000.0, lo_open=True), default=3.0),
        "contamination_fraction": ws.Number(ws.Interval(0.0, 0.5), default=0.05),
        "contamination_scale": ws.Number(ws.Interval(1.0, 1000.0), default=10.0),
    }, into=NoiseShape),
    "filters": ws.Section({
        "names": ws.StringList(NAMES),
        "initial_sigma_deg": ws.SigmaVector(2, ws.Interval(0.0, 30.0, lo_open=True), scale=DEG)
        .to("initial_sigma_rad"),
        **wc.settings_tables(),
    }, into=SpinningFilterSpec),
    "scoring": ws.Section({
        "blind_area_deg": ws.Number(ws.Interval(0.0, 90.0, lo_open=True), scale=DEG)
        .to("blind_area_rad"),
        "divergence_deg": wc.divergence(20.0),
    }, into=ScoringSpec),
    "sweep": ws.Section({
        "factors": Factors(default=[1.0, 2.0, 5.0, 10.0]),
        "gammas_rad": Gammas(default=[2.0, 5.0, 10.0, math.inf]),
        "distributions": ws.StringList(DISTRIBUTIONS, default=["gaussian"]),
        "runs_per_cell": ws.Integer(ws.Interval(0, 1000), default=5),
        "filters": ws.StringList(NAMES, default=list(NAMES)),
        "scales": ws.StringList(SCALES, default=["both"]),
    }, required=False, into=SweepSpec),
}, paper=PAPER)
SCHEMA = WORLD.schema


def _flight(launch: dict[str, Any], flight: dict[str, Any]) -> FlightSpec:
    return FlightSpec(speed_mps=launch["speed_mps"], pitch_rad=launch["pitch_deg"],
                      yaw_rad=launch["yaw_deg"], **flight)


MAX_FLIGHT_S = 1000.0
"""The flight integrator's horizon (:func:`slam.kinds.spinning.truth.fly`): a flight that
has not landed by then is refused, so no run samples more than this."""
MAX_DRAG = _FLIGHT["drag_k_per_m"].interval.hi
"""The largest drag constant a world may give; it bounds the calibrated one too."""


def flight_time_bound(f: FlightSpec) -> float:
    r"""An upper bound of the flight time (s), from the launch alone (no integration).

    With no drag the flight lasts :math:`T = 2 v_U / g` (:math:`v_U = v \sin` pitch).  With
    drag :math:`k > 0` (the calibrated one is at most :data:`MAX_DRAG`, and the bound
    grows with :math:`k`): the climb only loses speed faster than in vacuum, so it lasts
    at most :math:`v_U/g` and reaches at most :math:`h = v_U^2/2g`.  The horizontal speed
    relative to the wind only decays, so :math:`|v_{rel}| \le R_0 + s` with :math:`R_0`
    its value at launch and :math:`s` the sink rate; with the air density at most 1 the
    fall obeys :math:`\dot s \ge g - k (R_0 + s) s`, so :math:`\dot s \ge g/2` until
    :math:`s` reaches half of :math:`s^* = (\sqrt{R_0^2 + 4g/k} - R_0)/2` and :math:`s \ge
    s^*/2` after: the fall lasts at most :math:`\sqrt{4h/g} + 2h/s^*`.
    """
    vu = f.speed_mps * math.sin(f.pitch_rad)
    k = MAX_DRAG if f.drag_k_per_m is None else f.drag_k_per_m
    if k == 0.0:
        return 2.0 * vu / G
    h = vu * vu / (2.0 * G)
    r0 = math.hypot(f.speed_mps * math.cos(f.pitch_rad) * math.cos(f.yaw_rad),
                    -f.speed_mps * math.cos(f.pitch_rad) * math.sin(f.yaw_rad) - f.crosswind_mps)
    sink = (math.sqrt(r0 * r0 + 4.0 * G / k) - r0) / 2.0
    return vu / G + math.sqrt(4.0 * h / G) + 2.0 * h / sink


def work(w: SpinningWorld) -> Iterator[limits.Size]:
    """Samples (each a filter epoch), state and filter work of a run (:mod:`worlds.limits`),
    for the longest flight the launch allows (:func:`flight_time_bound`, at most
    :data:`MAX_FLIGHT_S`)."""
    bound = min(MAX_FLIGHT_S, flight_time_bound(w.flight))
    dt = w.sample_interval_s
    n = bound / dt + 1
    drag = ("the calibrated drag" if w.flight.drag_k_per_m is None
            else f"drag_k_per_m = {w.flight.drag_k_per_m:g}")
    why = f"a flight of up to {bound:.4g} s with {drag}, at sample_interval_s = {dt:g}"
    yield limits.Size("samples", "gyro and magnetometer samples", n, "sample_interval_s", why)
    yield limits.Size("epochs", "filter epochs", n, "sample_interval_s", why)
    yield limits.Size("state", "state dimensions", 2, None)
    yield limits.Size("work", "units of filter work", limits.filter_work(n, 0, 2, 2),
                      "sample_interval_s", why)


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None
          ) -> SpinningWorld:
    """Validate a parsed ``spinning`` TOML document and build its :class:`SpinningWorld`."""
    root = ws.Where(source, "")
    v = ws.read_table(data, SCHEMA, root)
    wc.check_settings(v["filters"], [*v["filters"]["names"], *v["sweep"]["filters"]],
                      root.child("filters"))
    return ws.build(WORLD, v, name=name, source=source,
                    flight=_flight(v["launch"], v["flight"]), roll0_rad=v["launch"]["roll_deg"])
