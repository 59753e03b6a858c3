"""A log's settings: the IMU noise, the GNSS σ, the site, the prior, the alignment and the
filters - read from a CSV log's sidecar TOML, or the documented KITTI table.

Sidecar TOML (``FILE.toml`` beside ``FILE.csv``; every key required unless marked)::

    [frames]
    navigation = "ENU"          # or "NED" (then body = "FRD")
    body = "FLU"                # or "FRD"
    [units]
    gyro = "rad/s"              # or "deg/s"
    accel = "m/s^2"             # or "g" (9.80665 m/s^2)
    [imu]                       # datasheet units (nav.imu_noise.datasheet_psd)
    arw_deg_sqrt_h = 0.15
    vrw_mps_sqrt_h = 0.06
    gyro_bias_instability_deg_h = 3.0       # optional (0: none), with gyro_bias_time_s
    gyro_bias_time_s = 300.0                # optional ("inf" or absent: no Markov part)
    gyro_rate_random_walk_deg_h_sqrt_h = 1  # optional (0: none)
    accel_bias_instability_mg = 0.05        # optional, with accel_bias_time_s
    accel_bias_time_s = 300.0               # optional
    accel_random_walk_mps2_sqrt_h = 0.001   # optional
    [gnss]
    position_sigma_m = 0.5      # used where the CSV has no sp column (or it is empty)
    velocity_sigma_mps = 0.1    # likewise for sv; needed only with velocity columns
    lever_arm_m = [0, 0, 0]     # optional, body frame, IMU to antenna
    [site]
    latitude_deg = 49.0         # WGS-84 normal gravity at latitude and height
    height_m = 110.0
    earth_rate = false          # optional (default false): Earth rotation in the model
    [initial]
    velocity_sigma_mps = 1.0
    roll_pitch_sigma_deg = 5.0
    heading_sigma_deg = 10.0
    gyro_bias_sigma_deg_h = 10.0
    accel_bias_sigma_mg = 10.0
    [alignment]
    min_speed_mps = 2.0         # the first fix this fast from the previous one starts
    [filters]
    names = ["ekf", "ckf", "ukf", "srckf"]   # optional (default DEFAULT_FILTERS)
    preintegration_fixes = 20   # optional (default PREINTEGRATION_FIXES): epochs
                                # preintegrated together, about the mean's biases at the
                                # first of them (1: each about its own mean's biases)
    [filters.unscented]                      # needed by ukf / srukf
    alpha = 1.0
    beta = 0.0
    kappa = 1.0
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nav.imu_noise import BiasProcess, ImuPsd, datasheet_psd, per_sample_density
from slam.kinds.ins_log.invariant import VARIANTS
from slam.kinds.recorded.log import LogFormatError
from worlds.common import TunedFilters

DEFAULT_FILTERS: tuple[str, ...] = ("ekf", "ckf", "ukf", "srckf")
PREINTEGRATION_FIXES = 20
"""The epochs (fix to fix) whose IMU increments are preintegrated in one batch
(:func:`nav.ins.preintegrate_stack`) about the filter mean's biases at the first of them; every
sigma point, the mean included, then moves to first order in its bias offset from that
reference (:func:`nav.ins.propagate_preintegrated`).  1 preintegrates each epoch about its
own mean's biases (the mean's prediction then is the mechanisation itself).  On KITTI 20
moves the SRCKF's positions by at most 3.2 mm from 1 (the gyro-bias estimate moves by up
to 4e-3 rad/s within a batch early in the drive) and costs 17 % less CPU (0.256 s against
0.307 s, ``benchmarks.kitti_speed``)."""
FILTERS = ("ekf", "ckf", "ukf", "srckf", "srukf", "srcdkf", "cdkf", *VARIANTS)
"""Every filter a log can run: the INS filters and their right-invariant variants
(:mod:`slam.kinds.ins_log.invariant`)."""
DEFAULT_SETTINGS: dict[str, dict[str, Any]] = {
    "unscented": {"alpha": 1.0, "beta": 0.0, "kappa": 1.0},
    "central_difference": {"h": math.sqrt(3.0)},
}
"""The filter settings of a log that states none (the report prints them): the unscented
set α = 1, β = 0, κ = 1 (points at √(n + 1) σ, every weight positive, on the 15-d state
not the cubature set) and the central-difference step √3."""


@dataclass(frozen=True)
class LogFilters(TunedFilters):
    """The filters run on the log and their settings."""

    names: tuple[str, ...] = DEFAULT_FILTERS


@dataclass(frozen=True)
class LogSettings:
    """Everything the estimators assume about a log (module docstring; SI)."""

    psd: ImuPsd
    position_sigma_m: float
    velocity_sigma_mps: float | None
    lever_arm_m: tuple[float, float, float]
    latitude_rad: float
    height_m: float
    earth_rate: bool
    velocity0_sigma_mps: float
    roll_pitch_sigma_rad: float
    heading_sigma_rad: float
    gyro_bias0_sigma: float
    accel_bias0_sigma: float
    min_speed_mps: float
    filters: LogFilters
    navigation: str = "ENU"
    body: str = "FLU"
    gyro_unit: str = "rad/s"
    accel_unit: str = "m/s^2"
    reading: str = ""
    stated: dict[str, Any] = field(default_factory=dict)
    preintegration_fixes: int = PREINTEGRATION_FIXES


KITTI_METADATA = ("BodyPtx", "BodyPty", "BodyPtz", "BodyPrx", "BodyPry", "BodyPrz",
                  "AccelerometerSigma", "GyroscopeSigma", "IntegrationSigma",
                  "AccelerometerBiasSigma", "GyroscopeBiasSigma", "AverageDeltaT")
KITTI_GNSS_SIGMA_M = math.sqrt(0.07)
KITTI_READING = (
    "KITTI (GTSAM's files): frames ENU/FLU (z up: the accelerometer reads +g at rest); "
    "AccelerometerSigma and GyroscopeSigma are continuous white-noise densities (per "
    "sqrt(Hz), as gtsam.PreintegrationParams takes them); AccelerometerBiasSigma and "
    "GyroscopeBiasSigma are random-walk steps per IMU sample of AverageDeltaT (GTSAM's "
    "example adds sqrt(n) sigma between fixes n samples apart), so their densities are "
    "sigma/sqrt(AverageDeltaT) (nav.imu_noise.per_sample_density); GNSS sigma sqrt(0.07) m "
    "per axis (the example's precision 1/0.07); site 49.0 deg N, 110 m (Karlsruhe) for "
    "WGS-84 gravity; no Earth rate; prior: position sigma = the GNSS sigma, velocity 1 m/s, "
    "roll/pitch 5 deg, heading 10 deg, gyro bias 5e-5 rad/s and accelerometer bias "
    "0.1 m/s^2 (the example's bias prior); alignment at the first fix 2 m/s from the "
    f"previous one; {PREINTEGRATION_FIXES} epochs preintegrated together (the sidecar key "
    "preintegration_fixes).")


KITTI_NOTE = (
    "GTSAM's IMUKittiExampleGPS.py adds sqrt(N) sigma to its bias between-factors with N the "
    "count of IMU samples integrated since the start of the log (a counter it never resets), "
    "so its bias noise at fix i is sqrt(i) times the per-sample reading above (10x at fix "
    "100, 20x at fix 400); this table is the stationary reading of the same numbers.")


def kitti_settings(meta: dict[str, float], filters: tuple[str, ...] | None) -> LogSettings:
    """The documented KITTI table (:data:`KITTI_READING`) from the metadata values."""
    dt = meta["AverageDeltaT"]
    psd = ImuPsd(meta["GyroscopeSigma"], meta["AccelerometerSigma"],
                 BiasProcess(walk_psd=per_sample_density(meta["GyroscopeBiasSigma"], dt) ** 2),
                 BiasProcess(walk_psd=per_sample_density(meta["AccelerometerBiasSigma"], dt)
                             ** 2))
    return LogSettings(psd, KITTI_GNSS_SIGMA_M, None, (meta["BodyPtx"], meta["BodyPty"],
                       meta["BodyPtz"]), math.radians(49.0), 110.0, False, 1.0,
                       math.radians(5.0), math.radians(10.0), 5e-5, 0.1, 2.0,
                       LogFilters(tuple(filters or DEFAULT_FILTERS), **DEFAULT_SETTINGS),
                       reading=f"{KITTI_READING} {KITTI_NOTE}", stated=dict(meta))


# --------------------------------------------------------------------------- sidecar

class _Table:
    """Checked reads from one table of the sidecar (errors name the file and key)."""

    def __init__(self, source: str, doc: dict[str, Any], name: str, required: bool = True):
        self.source, self.name = source, name
        t = doc.get(name)
        if t is None and not required:
            t = {}
        if not isinstance(t, dict):
            raise self.error(None, "missing table" if t is None else "must be a table")
        self.t = t

    def error(self, key: str | None, message: str) -> LogFormatError:
        where = f"[{self.name}]" + (f" {key}" if key else "")
        return LogFormatError(self.source, None, f"{where}: {message}")

    def number(self, key: str, lo: float, hi: float, default: float | None = None,
               allow_inf: bool = False) -> float:
        if key not in self.t:
            if default is None:
                raise self.error(key, f"missing (a number in [{lo:g}, {hi:g}])")
            return default
        v = self.t[key]
        if allow_inf and v == "inf":
            return math.inf
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise self.error(key, f"= {v!r}: must be a number in [{lo:g}, {hi:g}]")
        v = float(v)
        if not (math.isfinite(v) and lo <= v <= hi) or (v != 0.0 and abs(v) < 1e-300):
            raise self.error(key, f"= {v!r}: must be in [{lo:g}, {hi:g}]")
        return v

    def choice(self, key: str, allowed: tuple[str, ...], default: str | None = None) -> str:
        v = self.t.get(key, default)
        if v not in allowed:
            raise self.error(key, f"= {v!r}: must be one of {', '.join(allowed)}")
        return str(v)

    def flag(self, key: str, default: bool) -> bool:
        v = self.t.get(key, default)
        if not isinstance(v, bool):
            raise self.error(key, f"= {v!r}: must be true or false")
        return v


def _filters(source: str, doc: dict[str, Any], given: tuple[str, ...] | None) -> LogFilters:
    t = _Table(source, doc, "filters", required=False)
    names = t.t.get("names", list(DEFAULT_FILTERS))
    if not isinstance(names, list) or not names or not all(n in FILTERS for n in names):
        raise t.error("names", f"= {names!r}: a non-empty list from {', '.join(FILTERS)}")
    tables: dict[str, Any] = {}
    keys = {"unscented": (("alpha", 1e-4, 1.0), ("beta", 0.0, 10.0), ("kappa", -10.0, 100.0)),
            "central_difference": (("h", 1e-3, 100.0),)}
    for table, spec in keys.items():
        if table in t.t:
            sub = _Table(source, t.t, table)
            sub.name = f"filters.{table}"
            tables[table] = {k: sub.number(k, lo, hi) for k, lo, hi in spec}
    for table, default in DEFAULT_SETTINGS.items():
        tables.setdefault(table, default)
    return LogFilters(tuple(given or names), **tables)


def read_sidecar(path: Path, filters: tuple[str, ...] | None) -> LogSettings:
    """The sidecar TOML's settings (module docstring)."""
    source = str(path)
    try:
        doc = tomllib.loads(path.read_bytes().decode("utf-8"))
    except FileNotFoundError:
        raise LogFormatError(source, None, "missing: a CSV log needs its sidecar TOML "
                             "(frames, units, noise; see slam.kinds.ins_log)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise LogFormatError(source, None, f"cannot be read ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise LogFormatError(source, None, f"not valid TOML ({exc})") from None
    fr = _Table(source, doc, "frames")
    nav = fr.choice("navigation", ("ENU", "NED"))
    body = fr.choice("body", ("FLU", "FRD"))
    if (nav, body) not in (("ENU", "FLU"), ("NED", "FRD")):
        raise fr.error("body", f"= {body!r} with navigation {nav!r}: ENU/FLU or NED/FRD")
    un = _Table(source, doc, "units")
    gyro_unit = un.choice("gyro", ("rad/s", "deg/s"))
    accel_unit = un.choice("accel", ("m/s^2", "g"))
    imu = _Table(source, doc, "imu")
    psd = datasheet_psd(
        imu.number("arw_deg_sqrt_h", 0.0, 1e3), imu.number("vrw_mps_sqrt_h", 0.0, 1e3),
        gyro_bias_instability_deg_h=imu.number("gyro_bias_instability_deg_h", 0.0, 1e5, 0.0),
        gyro_bias_time_s=imu.number("gyro_bias_time_s", 1e-3, 1e9, math.inf, True),
        gyro_rate_random_walk_deg_h_sqrt_h=imu.number("gyro_rate_random_walk_deg_h_sqrt_h",
                                                      0.0, 1e5, 0.0),
        accel_bias_instability_mg=imu.number("accel_bias_instability_mg", 0.0, 1e5, 0.0),
        accel_bias_time_s=imu.number("accel_bias_time_s", 1e-3, 1e9, math.inf, True),
        accel_random_walk_mps2_sqrt_h=imu.number("accel_random_walk_mps2_sqrt_h", 0.0, 1e3,
                                                 0.0))
    if psd.gyro_density <= 0.0 or psd.accel_density <= 0.0:
        raise imu.error("arw_deg_sqrt_h", "the white-noise densities must be > 0")
    gn = _Table(source, doc, "gnss")
    arm = gn.t.get("lever_arm_m", [0.0, 0.0, 0.0])
    if (not isinstance(arm, list) or len(arm) != 3 or not all(
            isinstance(a, int | float) and not isinstance(a, bool) and math.isfinite(a)
            and abs(a) <= 100.0 for a in arm)):
        raise gn.error("lever_arm_m", f"= {arm!r}: three numbers in [-100, 100] m")
    vel = gn.number("velocity_sigma_mps", 1e-6, 1e3, -1.0)
    site = _Table(source, doc, "site")
    ini = _Table(source, doc, "initial")
    al = _Table(source, doc, "alignment")
    deg = math.radians(1.0)
    from nav.strapdown import G0

    return LogSettings(
        psd, gn.number("position_sigma_m", 1e-6, 1e5), None if vel < 0 else vel,
        (float(arm[0]), float(arm[1]), float(arm[2])),
        site.number("latitude_deg", -90.0, 90.0) * deg, site.number("height_m", -1e4, 1e5),
        site.flag("earth_rate", False), ini.number("velocity_sigma_mps", 1e-6, 1e3),
        ini.number("roll_pitch_sigma_deg", 1e-6, 90.0) * deg,
        ini.number("heading_sigma_deg", 1e-6, 180.0) * deg,
        ini.number("gyro_bias_sigma_deg_h", 1e-9, 1e6) * deg / 3600.0,
        ini.number("accel_bias_sigma_mg", 1e-9, 1e6) * G0 / 1000.0,
        al.number("min_speed_mps", 1e-3, 1e4), _filters(source, doc, filters),
        nav, body, gyro_unit, accel_unit, reading=f"sidecar {path.name}", stated=doc,
        preintegration_fixes=_preintegration_fixes(source, doc))


def _preintegration_fixes(source: str, doc: dict[str, Any]) -> int:
    t = _Table(source, doc, "filters", required=False)
    v = t.t.get("preintegration_fixes", PREINTEGRATION_FIXES)
    if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 1000:
        raise t.error("preintegration_fixes", f"= {v!r}: must be an integer in [1, 1000]")
    return v
