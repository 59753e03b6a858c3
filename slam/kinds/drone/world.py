"""The ``drone-slam`` world: a quaternion SINS/SLAM drone over terrain (SCENARIOS.md S2).

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
    [filters]  names, association ("known" | "nn"), gate_accept, gate_new, mode ("joint"),
               imu_noise_scale, sensor_noise_scale, divergence_m
    [paper]    free-form: the paper's reported numbers, passed through to summary.json

IMU defaults are industrial MEMS grade (a calibrated flight-controller IMU): gyro
angle random walk 0.3 °/√h, turn-on bias σ 30 °/h, bias random walk 3 °/h/√h;
accelerometer velocity random walk 0.06 m/s/√h, turn-on bias σ 3 mg, bias random walk
0.3 mg/√h.  A constant bias is drawn per run and axis from N(0, σ²); the random walks
and the white noise are per sample (``σ_rw·√dt`` and ``σ_wn/√dt``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib.resources.abc import Traversable
from typing import Any

import numpy as np

from estimators import wrap_angle
from slam.kinds.planar.world import MapSpec, filters_section
from worlds.schema import (
    Boolean,
    FreeForm,
    Integer,
    Interval,
    Number,
    Points,
    Section,
    String,
    Vector,
    Where,
    positive,
    read_table,
)

KIND = "drone-slam"
MODES = ("joint",)
TERRAIN_TYPES = ("flat", "hills", "mesh")

DEG = math.pi / 180.0
DEG_H = DEG / 3600.0  # deg/h -> rad/s
DEG_SQRT_H = DEG / 60.0  # deg/sqrt(h) -> rad/sqrt(s)
DEG_H_SQRT_H = DEG / 3600.0 / 60.0  # (deg/h)/sqrt(h) -> rad/s/sqrt(s)
MG = 9.80665e-3  # milli-g -> m/s^2
MG_SQRT_H = MG / 60.0  # mg/sqrt(h) -> m/s^2/sqrt(s)
MPS_SQRT_H = 1.0 / 60.0  # m/s/sqrt(h) -> m/s/sqrt(s)

_COORD = Interval(-1e6, 1e6)
_HILL_KEYS = ("hill_centres_m", "hill_amplitude_m", "hill_width_m")

SCHEMA = {
    "kind": String(choices=(KIND,)),
    "description": String(one_line=True, max_len=200),
    "runs": Integer(Interval(1, 100_000)),
    "seed": Integer(Interval(0, 2**63 - 1), default=0),
    "map": Section(
        {
            "bounds_m": Vector(4, _COORD),
            "landmarks": Points(),
            "waypoints": Points(),
        }
    ),
    "terrain": Section(
        {
            "type": String(choices=TERRAIN_TYPES, default="flat"),
            "base_height_m": Number(Interval(-1e4, 1e4), default=0.0),
            "grid_spacing_m": Number(Interval(0.1, 100.0), default=2.0),
            "margin_m": Number(Interval(0.0, 1e4), default=20.0),
            "hill_centres_m": Points(default=None, max_count=100),
            "hill_amplitude_m": Number(Interval(-1e3, 1e3), default=None),
            "hill_width_m": Number(positive(1e4), default=None),
            "mesh_file": String(default=None, one_line=True),
        },
        required=False,
    ),
    "vehicle": Section(
        {
            "speed_mps": Number(positive(30.0), default=3.0),
            "height_above_ground_m": Number(positive(500.0), default=5.0),
            "max_turn_rate_deg_s": Number(positive(360.0), 25.0, DEG),
            "max_turn_accel_deg_s2": Number(positive(3600.0), 30.0, DEG),
            "steer_gain_per_s": Number(positive(100.0), default=1.5),
            "at_waypoint_m": Number(positive(100.0), default=1.0),
            "loops": Integer(Interval(1, 100), default=2),
            "start_xy_m": Vector(2, _COORD),
            "start_heading_deg": Number(Interval(-360.0, 360.0), None, DEG),
            "altitude_smoothing_s": Number(Interval(0.0, 60.0), default=1.0),
            "drag_per_s": Number(Interval(0.0, 10.0), default=0.3),
            "initial_sigma_pos_m": Number(Interval(0.0, 100.0), default=0.0),
            "initial_sigma_vel_mps": Number(Interval(0.0, 10.0), default=0.02),
            "initial_sigma_roll_pitch_deg": Number(Interval(0.0, 30.0), 0.1, DEG),
            "initial_sigma_yaw_deg": Number(Interval(0.0, 180.0), 0.2, DEG),
        }
    ),
    "imu": Section(
        {
            "rate_hz": Number(Interval(1.0, 10_000.0), default=100.0),
            "gravity_mps2": Number(Interval(0.0, 30.0), default=9.80665),
            "earth_rate": Boolean(default=False),
            "latitude_deg": Number(Interval(-90.0, 90.0), 34.75, DEG),
            "gyro_bias_sigma_deg_h": Number(Interval(0.0, 1e5), 30.0, DEG_H),
            "gyro_bias_rw_deg_h_sqrt_h": Number(Interval(0.0, 1e4), 3.0, DEG_H_SQRT_H),
            "gyro_arw_deg_sqrt_h": Number(Interval(0.0, 100.0), 0.3, DEG_SQRT_H),
            "accel_bias_sigma_mg": Number(Interval(0.0, 1000.0), 3.0, MG),
            "accel_bias_rw_mg_sqrt_h": Number(Interval(0.0, 1000.0), 0.3, MG_SQRT_H),
            "accel_vrw_mps_sqrt_h": Number(Interval(0.0, 100.0), 0.06, MPS_SQRT_H),
        },
        required=False,
    ),
    "sensor": Section(
        {
            "rate_hz": Number(Interval(0.001, 1000.0), default=5.0),
            "max_range_m": Number(positive(10_000.0), default=30.0),
            "min_range_m": Number(Interval(0.0, 10_000.0), default=1.0),
            "fov_azimuth_half_deg": Number(positive(180.0), 90.0, DEG),
            "fov_elevation_half_deg": Number(positive(85.0), 60.0, DEG),
            "sigma_range_m": Number(positive(100.0), default=0.1),
            "sigma_azimuth_deg": Number(positive(45.0), 1.0, DEG),
            "sigma_elevation_deg": Number(positive(45.0), 1.0, DEG),
            "line_of_sight": Boolean(default=True),
            "los_margin_m": Number(Interval(0.0, 100.0), default=0.1),
        },
        required=False,
    ),
    "filters": filters_section(
        MODES, gate_accept=7.8, gate_new=30.0,
        imu_noise_scale=Number(positive(1e6), default=1.0),
        sensor_noise_scale=Number(positive(1e6), default=1.0),
        divergence_m=Number(positive(1e6), default=25.0),
    ),
    "paper": FreeForm(default=dict),
}


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
class ImuSpec:
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

    @property
    def dt_s(self) -> float:
        return 1.0 / self.rate_hz


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
class DroneFilterSpec:
    """Filters, association, and what the filters assume: the IMU and sensor noise
    variances of the world times ``imu_noise_scale`` / ``sensor_noise_scale``.  A run
    whose position error exceeds ``divergence_m`` is stopped and reported diverged."""

    names: tuple[str, ...] = ("ekf", "srckf", "srukf", "srcdkf")
    association: str = "known"
    gate_accept: float = 7.8
    gate_new: float = 30.0
    mode: str = "joint"
    imu_noise_scale: float = 1.0
    sensor_noise_scale: float = 1.0
    divergence_m: float = 25.0


@dataclass(frozen=True)
class DroneWorld:
    """A validated drone world.  ``paper`` is free-form (JSON-compatible)."""

    name: str
    kind: str
    description: str
    map: MapSpec
    terrain: TerrainSpec
    vehicle: DroneVehicleSpec
    imu: ImuSpec
    sensor: LandmarkSensorSpec
    filters: DroneFilterSpec
    runs: int
    seed: int = 0
    paper: dict[str, Any] = field(default_factory=dict)
    source: str = ""

    @property
    def samples_per_epoch(self) -> int:
        """IMU samples per landmark-sensor period (one filter epoch)."""
        return int(round(self.imu.rate_hz / self.sensor.rate_hz))


def _is_whole(x: float, tol: float = 1e-9) -> bool:
    return abs(x - round(x)) <= tol * max(1.0, abs(x))


def _inside(points: np.ndarray, bounds: tuple[float, ...]) -> np.ndarray:
    xmin, xmax, ymin, ymax = bounds
    return ((points[:, 0] >= xmin) & (points[:, 0] <= xmax)
            & (points[:, 1] >= ymin) & (points[:, 1] <= ymax))


def _terrain(t: dict[str, Any], data: dict[str, Any], base: Traversable | None,
             at: Where) -> TerrainSpec:
    kind = t["type"]
    given = data.get("terrain", {}) if isinstance(data.get("terrain"), dict) else {}
    if kind != "hills":
        for key in _HILL_KEYS:
            if key in given:
                raise at.child(key).error('only used with type = "hills"', given[key])
    if kind != "mesh" and "mesh_file" in given:
        raise at.child("mesh_file").error('only used with type = "mesh"', given["mesh_file"])
    centres: tuple[tuple[float, float], ...] = ()
    amplitude, width = 0.0, 1.0
    mesh_path = None
    if kind == "hills":
        for key in _HILL_KEYS:
            if t[key] is None:
                raise at.child(key).error('missing (required with type = "hills")')
        if len(t["hill_centres_m"]) < 1:
            raise at.child("hill_centres_m").error("needs at least one hill centre", [])
        centres = tuple((float(x), float(y)) for x, y in t["hill_centres_m"])
        amplitude, width = t["hill_amplitude_m"], t["hill_width_m"]
    if kind == "mesh":
        rel = t["mesh_file"]
        if rel is None:
            raise at.child("mesh_file").error('missing (required with type = "mesh")')
        if base is None:
            raise at.child("mesh_file").error("a mesh file needs a world file to be "
                                              "relative to", rel)
        target = base.joinpath(rel)
        if not target.is_file():
            raise at.child("mesh_file").error("file not found", rel)
        mesh_path = str(target)
    return TerrainSpec(kind, t["base_height_m"], t["grid_spacing_m"], t["margin_m"], centres,
                       amplitude, width, t["mesh_file"], mesh_path)


def parse(data: dict[str, Any], name: str, source: str, base: Traversable | None
          ) -> DroneWorld:
    """Validate a parsed ``drone-slam`` TOML document and build its :class:`DroneWorld`.

    ``source`` is the file name shown in errors; ``base`` the folder a mesh file is read
    from.  Whether a mesh file covers the map is checked when its terrain is built.
    """
    root = Where(source, "")
    v = read_table(data, SCHEMA, root)
    m, veh, imu, sen, fil = v["map"], v["vehicle"], v["imu"], v["sensor"], v["filters"]
    at_map = root.child("map")

    bounds = m["bounds_m"]
    if not (bounds[0] < bounds[1] and bounds[2] < bounds[3]):
        raise at_map.child("bounds_m").error(
            "must be [xmin, xmax, ymin, ymax] with min < max", list(bounds))
    for key, least in (("landmarks", 1), ("waypoints", 2)):
        pts = m[key]
        outside = np.flatnonzero(~_inside(pts, bounds))
        if outside.size:
            i = int(outside[0])
            raise at_map.child(key).item(i).error(
                f"outside the map bounds_m {list(bounds)}", pts[i].tolist())
        if len(pts) < least:
            raise at_map.child(key).error(f"needs at least {least}", pts.tolist())

    at_veh = root.child("vehicle")
    sx, sy = veh["start_xy_m"]
    if not _inside(np.array([[sx, sy]]), bounds)[0]:
        raise at_veh.child("start_xy_m").error(f"outside the map bounds_m {list(bounds)}",
                                               [sx, sy])
    heading = veh["start_heading_deg"]
    if heading is None:  # towards the first waypoint
        wx, wy = m["waypoints"][0]
        heading = math.atan2(wy - sy, wx - sx) if (wx, wy) != (sx, sy) else 0.0
    heading = wrap_angle(float(heading))

    ratio = imu["rate_hz"] / sen["rate_hz"]
    if not (_is_whole(ratio) and round(ratio) >= 1):
        raise root.child("sensor.rate_hz").error(
            f"must divide the IMU rate ({imu['rate_hz']:g} Hz) a whole number of times",
            sen["rate_hz"])
    if sen["min_range_m"] >= sen["max_range_m"]:
        raise root.child("sensor.min_range_m").error(
            f"must be below max_range_m ({sen['max_range_m']:g})", sen["min_range_m"])
    if fil["gate_new"] < fil["gate_accept"]:
        raise root.child("filters.gate_new").error(
            f"must be >= gate_accept ({fil['gate_accept']:g})", fil["gate_new"])

    terrain = _terrain(v["terrain"], data, base, root.child("terrain"))
    return DroneWorld(
        name=name,
        kind=v["kind"],
        description=v["description"],
        map=MapSpec(bounds, m["landmarks"], m["waypoints"]),
        terrain=terrain,
        vehicle=DroneVehicleSpec(
            speed_mps=veh["speed_mps"],
            height_above_ground_m=veh["height_above_ground_m"],
            max_turn_rate_rad_s=veh["max_turn_rate_deg_s"],
            max_turn_accel_rad_s2=veh["max_turn_accel_deg_s2"],
            steer_gain_per_s=veh["steer_gain_per_s"],
            at_waypoint_m=veh["at_waypoint_m"],
            loops=veh["loops"],
            start_xy=(sx, sy),
            start_heading_rad=heading,
            altitude_smoothing_s=veh["altitude_smoothing_s"],
            drag_per_s=veh["drag_per_s"],
            initial_sigma_pos_m=veh["initial_sigma_pos_m"],
            initial_sigma_vel_mps=veh["initial_sigma_vel_mps"],
            initial_sigma_roll_pitch_rad=veh["initial_sigma_roll_pitch_deg"],
            initial_sigma_yaw_rad=veh["initial_sigma_yaw_deg"],
        ),
        imu=ImuSpec(
            rate_hz=imu["rate_hz"],
            gravity_mps2=imu["gravity_mps2"],
            earth_rate=imu["earth_rate"],
            latitude_rad=imu["latitude_deg"],
            gyro_bias_sigma=imu["gyro_bias_sigma_deg_h"],
            gyro_bias_rw=imu["gyro_bias_rw_deg_h_sqrt_h"],
            gyro_arw=imu["gyro_arw_deg_sqrt_h"],
            accel_bias_sigma=imu["accel_bias_sigma_mg"],
            accel_bias_rw=imu["accel_bias_rw_mg_sqrt_h"],
            accel_vrw=imu["accel_vrw_mps_sqrt_h"],
        ),
        sensor=LandmarkSensorSpec(
            rate_hz=sen["rate_hz"],
            max_range_m=sen["max_range_m"],
            min_range_m=sen["min_range_m"],
            fov_azimuth_half_rad=sen["fov_azimuth_half_deg"],
            fov_elevation_half_rad=sen["fov_elevation_half_deg"],
            sigma_range_m=sen["sigma_range_m"],
            sigma_azimuth_rad=sen["sigma_azimuth_deg"],
            sigma_elevation_rad=sen["sigma_elevation_deg"],
            line_of_sight=sen["line_of_sight"],
            los_margin_m=sen["los_margin_m"],
        ),
        filters=DroneFilterSpec(**fil),
        runs=v["runs"],
        seed=v["seed"],
        paper=v["paper"],
        source=source,
    )
