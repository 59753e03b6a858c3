"""The ``drone-slam`` world: a quaternion SINS/SLAM drone over terrain (docs/kinds/drone.md).

A multirotor flies a waypoint loop at a constant height above the ground among point
landmarks that sit on the ground; a strapdown IMU (gyro + accelerometer, each with a
constant bias, a bias random walk and white noise) drives the prediction, a landmark
sensor (range, azimuth, elevation in the body frame) the updates.  Units are spelled in
every key and converted to SI radians on load; the dataclasses name their SI units.
Frames: ENU navigation frame (x east, y north, z up), forward-left-up body frame.
File layout::

    kind = "drone-slam"
    description = "one line"
    runs = 20                   # Monte Carlo runs
    seed = 0                    # optional
    [map]      bounds_m = [xmin, xmax, ymin, ymax]; landmarks = [[x, y], ...] (placed on the
               terrain: z = ground height); waypoints = [[x, y], ...]
    [terrain]  type ("flat" | "hills" | "mesh"), base_height_m, grid_spacing_m, margin_m;
               hills: hill_centres_m = [[x, y], ...], hill_amplitude_m, hill_width_m
               (z = base + A·Σ exp(-|xy - c|² / 2w²)); mesh: mesh_file (relative to the
               world file; must cover the map)
    [vehicle]  speed_mps, height_above_ground_m, max_turn_rate_deg_s, max_turn_accel_deg_s2,
               steer_gain_per_s, at_waypoint_m, loops, start_xy_m, start_heading_deg,
               altitude_smoothing_s, drag_per_s, initial_sigma_pos_m, initial_sigma_vel_mps,
               initial_sigma_roll_pitch_deg, initial_sigma_yaw_deg
    [imu]      rate_hz, gravity_mps2, earth_rate, latitude_deg,
               gyro_bias_sigma_deg_h, gyro_bias_rw_deg_h_sqrt_h, gyro_arw_deg_sqrt_h,
               accel_bias_sigma_mg, accel_bias_rw_mg_sqrt_h, accel_vrw_mps_sqrt_h
    [sensor]   rate_hz, max_range_m, min_range_m, fov_azimuth_half_deg,
               fov_elevation_half_deg, sigma_range_m, sigma_azimuth_deg, sigma_elevation_deg,
               line_of_sight, los_margin_m
    [filters]  names (also srckf-inv, ekf-inv, ...: slam/kinds/drone/variants.py),
               association ("known" | "nn"), gate_accept, gate_new, mode ("joint" | "local";
               local: ekf, srckf, srukf, srcdkf and their -inv), imu_noise_scale,
               sensor_noise_scale, divergence_m, online (true: also score iSAM2's state
               after every epoch, row "isam2"; off by default: slam/kinds/drone/online.py)
    [paper]    free-form: the paper's reported numbers, passed through to summary.json

IMU defaults are industrial MEMS grade (a calibrated flight-controller IMU): gyro
angle random walk 0.3 °/√h, turn-on bias σ 30 °/h, bias random walk 3 °/h/√h;
accelerometer velocity random walk 0.06 m/s/√h, turn-on bias σ 3 mg, bias random walk
0.3 mg/√h.  A constant bias is drawn per run and axis from N(0, σ²); the random walks
and the white noise are per sample (``σ_rw·√dt`` and ``σ_wn/√dt``).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from typing import Any

import worlds.common as wc
import worlds.schema as ws
from slam.kinds.drone.variants import DRONE_FILTERS, DRONE_LOCAL_FILTERS
from slam.kinds.planar.world import (
    COORD,
    GATES,
    MODES,
    FilterSpec,
    MapSpec,
    check_bounds,
    check_inside,
    check_local_mode,
    filters_section,
    start_pose,
)
from worlds import limits
from worlds.units import DEG, DEG_H, DEG_H_SQRT_H, DEG_SQRT_H, MG, MG_SQRT_H, MPS_SQRT_H

KIND = "drone-slam"
TERRAIN_TYPES = ("flat", "hills", "mesh")

_HILL_KEYS = ("hill_centres_m", "hill_amplitude_m", "hill_width_m")


@dataclass(frozen=True)
class TerrainSpec:
    """How to build the ground mesh (see :mod:`nav.terrain`); heights in metres.

    ``kind``: ``"flat"`` (a plane at ``base_height_m``), ``"hills"`` (Gaussian bumps at
    ``hill_centres`` with ``hill_amplitude_m`` and σ ``hill_width_m``, gridded every
    ``grid_spacing_m``) or ``"mesh"`` (``mesh_path``, as named by ``mesh_file``).
    Flat and hills meshes extend ``margin_m`` beyond the map bounds.
    """

    kind: str = "flat"
    base_height_m: float = 0.0
    grid_spacing_m: float = 2.0
    margin_m: float = 20.0
    hill_centres: tuple[tuple[float, float], ...] = ()
    hill_amplitude_m: float = 0.0
    hill_width_m: float = 1.0
    mesh_file: str | None = None
    mesh_path: str | None = None


@dataclass(frozen=True)
class DroneVehicleSpec:
    """The drone's flight plan and the filters' initial uncertainty (SI, radians).

    Steering (a Bailey-style waypoint law for a multirotor): the commanded turn rate is
    ``steer_gain_per_s`` times the bearing error to the current waypoint, limited to
    ``max_turn_rate_rad_s``, and it changes at most at ``max_turn_accel_rad_s2``.  The
    altitude reference (ground height + ``height_above_ground_m``) is smoothed over
    ``altitude_smoothing_s`` (σ of a Gaussian in time) to bound the vertical acceleration.
    ``drag_per_s``: linear drag per unit mass; the thrust axis tilts to cancel it (the
    drone flies nose-down), see :mod:`slam.kinds.drone.flight`.
    """

    speed_mps: float = 3.0
    height_above_ground_m: float = 5.0
    max_turn_rate_rad_s: float = 25.0 * DEG
    max_turn_accel_rad_s2: float = 30.0 * DEG
    steer_gain_per_s: float = 1.5
    at_waypoint_m: float = 1.0
    loops: int = 2
    start_xy: tuple[float, float] = (0.0, 0.0)
    start_heading_rad: float = 0.0
    altitude_smoothing_s: float = 1.0
    drag_per_s: float = 0.3
    initial_sigma_pos_m: float = 0.0
    initial_sigma_vel_mps: float = 0.02
    initial_sigma_roll_pitch_rad: float = 0.1 * DEG
    initial_sigma_yaw_rad: float = 0.2 * DEG


@dataclass(frozen=True)
class ImuSpec(wc.Sampled):
    """Strapdown IMU at ``rate_hz`` (SI units; densities per √s).

    Gyro (rad/s): ``ω̃ = ω + b_g + n_g``; accelerometer (m/s²): ``f̃ = f + b_a + n_a``.
    ``*_bias_sigma``: std of the constant (turn-on) bias drawn per run and axis;
    ``*_bias_rw``: bias random-walk density (``b += σ·√dt·N(0, 1)`` per sample);
    ``gyro_arw`` (rad/√s) and ``accel_vrw`` (m/s/√s): white-noise densities (``σ/√dt``
    per sample).  ``earth_rate``: include the Earth's rotation at ``latitude_rad``.
    """

    rate_hz: float = 100.0
    gravity_mps2: float = 9.80665
    earth_rate: bool = False
    latitude_rad: float = 34.75 * DEG
    gyro_bias_sigma: float = 30.0 * DEG_H
    gyro_bias_rw: float = 3.0 * DEG_H_SQRT_H
    gyro_arw: float = 0.3 * DEG_SQRT_H
    accel_bias_sigma: float = 3.0 * MG
    accel_bias_rw: float = 0.3 * MG_SQRT_H
    accel_vrw: float = 0.06 * MPS_SQRT_H


@dataclass(frozen=True)
class LandmarkSensorSpec:
    """Range / azimuth / elevation of landmarks in the body frame, every ``1/rate_hz`` s.

    Visible: ``min_range_m <= r <= max_range_m``, ``|azimuth| <= fov_azimuth_half_rad``,
    ``|elevation| <= fov_elevation_half_rad`` and, with ``line_of_sight``, the segment
    from the drone to the landmark (stopped ``los_margin_m`` short) clear of the terrain.
    """

    rate_hz: float = 5.0
    max_range_m: float = 30.0
    min_range_m: float = 1.0
    fov_azimuth_half_rad: float = 90.0 * DEG
    fov_elevation_half_rad: float = 60.0 * DEG
    sigma_range_m: float = 0.1
    sigma_azimuth_rad: float = 1.0 * DEG
    sigma_elevation_rad: float = 1.0 * DEG
    line_of_sight: bool = True
    los_margin_m: float = 0.1


@dataclass(frozen=True)
class DroneFilterSpec(FilterSpec):
    """The planar SLAM filter spec with the drone's gates, and what the filters assume:
    the IMU and sensor noise variances of the world times ``imu_noise_scale`` /
    ``sensor_noise_scale``.  A run whose position error exceeds ``divergence_m`` is
    stopped and reported diverged.  ``online`` adds the online row ``isam2`` (iSAM2's
    state and marginal after every epoch, :mod:`slam.kinds.drone.online`)."""

    gate_accept: float = 7.8
    gate_new: float = 30.0
    imu_noise_scale: float = 1.0
    sensor_noise_scale: float = 1.0
    divergence_m: float = 25.0
    online: bool = False


@dataclass(frozen=True)
class DroneWorld(wc.WorldBase):
    """A validated drone world."""

    map: MapSpec
    terrain: TerrainSpec
    vehicle: DroneVehicleSpec
    imu: ImuSpec
    sensor: LandmarkSensorSpec
    filters: DroneFilterSpec

    samples_per_epoch = wc.per_epoch("imu", "sensor",
                                     "IMU samples per landmark-sensor period (one filter epoch)")


WORLD = wc.world(KIND, DroneWorld, {
    "map": ws.Section(
        {
            "bounds_m": ws.Vector(4, COORD),
            "landmarks": ws.Points(),
            "waypoints": ws.Points(),
        }
    ),
    "terrain": ws.Section(
        {
            "type": ws.String(choices=TERRAIN_TYPES, default="flat").to("kind"),
            "base_height_m": ws.Number(ws.Interval(-1e4, 1e4), default=0.0),
            "grid_spacing_m": ws.Number(ws.Interval(0.1, 100.0), default=2.0),
            "margin_m": ws.Number(ws.Interval(0.0, 1e4), default=20.0),
            "hill_centres_m": ws.Points(default=None, max_count=100).to("hill_centres"),
            "hill_amplitude_m": ws.Number(ws.Interval(-1e3, 1e3), default=None),
            "hill_width_m": ws.Number(ws.positive(1e4), default=None),
            "mesh_file": ws.String(default=None, one_line=True),
        },
        required=False,
        into=TerrainSpec,
    ),
    "vehicle": ws.Section(
        {
            "speed_mps": ws.Number(ws.positive(30.0), default=3.0),
            "height_above_ground_m": ws.Number(ws.positive(500.0), default=5.0),
            "max_turn_rate_deg_s": ws.Number(ws.positive(360.0), 25.0, DEG)
            .to("max_turn_rate_rad_s"),
            "max_turn_accel_deg_s2": ws.Number(ws.positive(3600.0), 30.0, DEG)
            .to("max_turn_accel_rad_s2"),
            "steer_gain_per_s": ws.Number(ws.positive(100.0), default=1.5),
            "at_waypoint_m": ws.Number(ws.positive(100.0), default=1.0),
            "loops": ws.Integer(ws.Interval(1, 100), default=2),
            "start_xy_m": ws.Vector(2, COORD).to("start_xy"),
            "start_heading_deg": ws.Number(ws.Interval(-360.0, 360.0), None, DEG)
            .to("start_heading_rad"),
            "altitude_smoothing_s": ws.Number(ws.Interval(0.0, 60.0), default=1.0),
            "drag_per_s": ws.Number(ws.Interval(0.0, 10.0), default=0.3),
            "initial_sigma_pos_m": ws.Sigma(ws.Interval(0.0, 100.0), default=0.0),
            "initial_sigma_vel_mps": ws.Sigma(ws.Interval(0.0, 10.0), default=0.02),
            "initial_sigma_roll_pitch_deg": ws.Sigma(ws.Interval(0.0, 30.0), 0.1, DEG)
            .to("initial_sigma_roll_pitch_rad"),
            "initial_sigma_yaw_deg": ws.Sigma(ws.Interval(0.0, 180.0), 0.2, DEG)
            .to("initial_sigma_yaw_rad"),
        },
        into=DroneVehicleSpec,
    ),
    "imu": ws.Section(
        {
            "rate_hz": ws.Number(ws.Interval(1.0, 10_000.0), default=100.0),
            "gravity_mps2": ws.Number(ws.Interval(0.0, 30.0), default=9.80665),
            "earth_rate": ws.Boolean(default=False),
            "latitude_deg": ws.Number(ws.Interval(-90.0, 90.0), 34.75, DEG).to("latitude_rad"),
            "gyro_bias_sigma_deg_h": wc.nonnegative(1e5, DEG_H, "gyro_bias_sigma", 30.0),
            "gyro_bias_rw_deg_h_sqrt_h": wc.nonnegative(1e4, DEG_H_SQRT_H, "gyro_bias_rw", 3.0),
            "gyro_arw_deg_sqrt_h": wc.nonnegative(100.0, DEG_SQRT_H, "gyro_arw", 0.3),
            "accel_bias_sigma_mg": wc.nonnegative(1000.0, MG, "accel_bias_sigma", 3.0),
            "accel_bias_rw_mg_sqrt_h": wc.nonnegative(1000.0, MG_SQRT_H, "accel_bias_rw", 0.3),
            "accel_vrw_mps_sqrt_h": wc.nonnegative(100.0, MPS_SQRT_H, "accel_vrw", 0.06),
        },
        required=False,
        into=ImuSpec,
    ),
    "sensor": ws.Section(
        {
            "rate_hz": ws.Number(ws.Interval(0.001, 1000.0), default=5.0),
            "max_range_m": ws.Number(ws.positive(10_000.0), default=30.0),
            "min_range_m": ws.Number(ws.Interval(0.0, 10_000.0), default=1.0),
            "fov_azimuth_half_deg": ws.Number(ws.positive(180.0), 90.0, DEG)
            .to("fov_azimuth_half_rad"),
            "fov_elevation_half_deg": ws.Number(ws.positive(85.0), 60.0, DEG)
            .to("fov_elevation_half_rad"),
            "sigma_range_m": ws.Sigma(ws.positive(100.0), default=0.1),
            "sigma_azimuth_deg": ws.Sigma(ws.positive(45.0), 1.0, DEG).to("sigma_azimuth_rad"),
            "sigma_elevation_deg": ws.Sigma(ws.positive(45.0), 1.0, DEG).to("sigma_elevation_rad"),
            "line_of_sight": ws.Boolean(default=True),
            "los_margin_m": ws.Number(ws.Interval(0.0, 100.0), default=0.1),
        },
        required=False,
        into=LandmarkSensorSpec,
    ),
    "filters": filters_section(
        MODES, DroneFilterSpec, gate_accept=7.8, gate_new=30.0, names=DRONE_FILTERS,
        imu_noise_scale=ws.Sigma(ws.positive(1e6), default=1.0, power=1),
        sensor_noise_scale=ws.Sigma(ws.positive(1e6), default=1.0, power=1),
        divergence_m=ws.Number(ws.positive(1e6), default=25.0),
        online=ws.Boolean(default=False),
    ),
}, paper=wc.PAPER_RANGES)
SCHEMA = WORLD.schema

RULES = (
    wc.divides_rate("sensor.rate_hz", "imu.rate_hz", "IMU"),
    wc.below("sensor.min_range_m", "sensor.max_range_m"),
    GATES,
)
"""Checks across keys, in the order they are made."""


def _check_terrain_keys(kind: str, data: dict[str, Any], at: ws.Where) -> None:
    """Hill keys only with ``type = "hills"``, ``mesh_file`` only with ``"mesh"``."""
    given = data.get("terrain", {}) if isinstance(data.get("terrain"), dict) else {}
    if kind != "hills":
        for key in _HILL_KEYS:
            if key in given:
                raise at.child(key).error('only used with type = "hills"', given[key])
    if kind != "mesh" and "mesh_file" in given:
        raise at.child("mesh_file").error('only used with type = "mesh"', given["mesh_file"])


def _hills(t: dict[str, Any], at: ws.Where) -> dict[str, Any]:
    """The hill fields of a ``type = "hills"`` terrain (all three keys required)."""
    for key in _HILL_KEYS:
        if t[key] is None:
            raise at.child(key).error('missing (required with type = "hills")')
    if len(t["hill_centres_m"]) < 1:
        raise at.child("hill_centres_m").error("needs at least one hill centre", [])
    return {"hill_centres": tuple((float(x), float(y)) for x, y in t["hill_centres_m"]),
            "hill_amplitude_m": t["hill_amplitude_m"], "hill_width_m": t["hill_width_m"]}


def _mesh_path(rel: str | None, base: Traversable | None, at: ws.Where) -> str:
    """The path of a ``type = "mesh"`` terrain's file, relative to the world file."""
    if rel is None:
        raise at.error('missing (required with type = "mesh")')
    if base is None:
        raise at.error("a mesh file needs a world file to be relative to", rel)
    target = base.joinpath(rel)
    limits.check_file(target, lambda why: at.error(why, rel))
    return str(target)


def _terrain(t: dict[str, Any], data: dict[str, Any], base: Traversable | None,
             at: ws.Where) -> TerrainSpec:
    kind = t["type"]
    _check_terrain_keys(kind, data, at)
    hills = (_hills(t, at) if kind == "hills" else
             {"hill_centres": (), "hill_amplitude_m": 0.0, "hill_width_m": 1.0})
    mesh_path = _mesh_path(t["mesh_file"], base, at.child("mesh_file")) if kind == "mesh" else None
    return ws.build(SCHEMA["terrain"], t, mesh_path=mesh_path, **hills)


def _samples(length: float, speed: float, rate: float) -> float:
    """IMU samples to fly ``length`` metres at ``speed`` (``inf`` when it overflows)."""
    try:
        return length / speed * rate
    except (OverflowError, ZeroDivisionError):
        return math.inf


def check_smoothing(w: DroneWorld, root: ws.Where) -> None:
    """An altitude smoothing of at least one IMU period (or none)."""
    veh, imu = w.vehicle, w.imu
    if 0.0 < veh.altitude_smoothing_s < imu.dt_s:
        raise root.child("vehicle.altitude_smoothing_s").error(
            f"must be 0 (no smoothing) or at least one IMU period ({imu.dt_s:g} s)",
            veh.altitude_smoothing_s)


def work(w: DroneWorld) -> Iterator[limits.Size]:
    """What one run costs (:mod:`worlds.limits`): IMU samples, sensor epochs, the gridded
    terrain, the state if every landmark near the path is mapped, the filter work - in
    that order (the landmarks near the path are counted only for an allowed path)."""
    veh, imu, sen = w.vehicle, w.imu, w.sensor
    length = limits.path_length(veh.start_xy, w.map.waypoints, veh.loops)
    samples = _samples(length, veh.speed_mps, imu.rate_hz)
    yield limits.Size("samples", "IMU samples", samples, "vehicle.speed_mps",
                      f"a {length:.4g} m path at speed_mps = {veh.speed_mps:g}, "
                      f"{imu.rate_hz:g} Hz")
    epochs = samples / w.samples_per_epoch + 1
    yield limits.Size("epochs", "sensor epochs", epochs, "sensor.rate_hz")
    t, (x0, x1, y0, y1) = w.terrain, w.map.bounds_m
    if t.kind == "hills":
        span = (x1 - x0 + 2 * t.margin_m) * (y1 - y0 + 2 * t.margin_m)
        yield limits.Size("vertices", "terrain grid vertices", span / t.grid_spacing_m**2,
                          "terrain.grid_spacing_m")
    reach = sen.max_range_m + veh.at_waypoint_m + 2.0 * veh.speed_mps / veh.max_turn_rate_rad_s
    near = limits.near_path(w.map.landmarks, veh.start_xy, w.map.waypoints, reach)
    state = 15 + 3 * near
    yield limits.Size("state", "state dimensions", state, "map.landmarks",
                      f"{near} landmarks within sensor range of the path")
    n = w.samples_per_epoch
    cost = epochs * ((state**3 if w.filters.mode == "joint" else 15**3 + 10 * state**2)
                     + 40 * state * n)
    yield limits.Size("work", "units of filter work", cost, "filters.mode",
                      f"{limits.count(epochs)} epochs, state {state}, {n} IMU samples per "
                      f"epoch, {w.filters.mode} mode")


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None
          ) -> DroneWorld:
    """Validate a parsed ``drone-slam`` TOML document and build its :class:`DroneWorld`.

    ``source`` is the file name shown in errors; ``base`` the folder a mesh file is read
    from.  Whether a mesh file covers the map is checked when its terrain is built.
    """
    root = ws.Where(source, "")
    v = ws.read_table(data, SCHEMA, root)
    m, at_map = v["map"], root.child("map")
    check_bounds(m["bounds_m"], at_map.child("bounds_m"))
    for key, least in (("landmarks", 1), ("waypoints", 2)):
        check_inside(m[key], m["bounds_m"], at_map.child(key))
        if len(m[key]) < least:
            raise at_map.child(key).error(f"needs at least {least}", m[key].tolist())
    sx, sy, heading = start_pose(v["vehicle"], m["bounds_m"], m["waypoints"],
                                 root.child("vehicle"))
    check_local_mode(v["filters"], root.child("filters.mode"), DRONE_LOCAL_FILTERS)
    wc.check_settings(v["filters"], v["filters"]["names"], root.child("filters"))
    ws.check_rules(RULES, v, root)
    world = ws.build(
        WORLD, v, name=name, source=source,
        map=MapSpec(m["bounds_m"], m["landmarks"], m["waypoints"]),
        terrain=_terrain(v["terrain"], data, base, root.child("terrain")),
        vehicle=ws.build(SCHEMA["vehicle"], v["vehicle"], start_xy=(sx, sy),
                         start_heading_rad=heading),
    )
    check_smoothing(world, root)
    return world
