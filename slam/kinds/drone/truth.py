"""The drone world's truth: terrain mesh, flight plan, navigation frame and the flown
trajectory with the landmarks on the ground (deterministic per world; cached)."""

from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np

from estimators.linalg import Array
from nav.strapdown import earth_rate_enu, gravity_enu
from slam.kinds.drone.flight import FlightPlan, Trajectory, fly
from slam.kinds.drone.models import (
    NavFrame,
)
from worlds import limits

if TYPE_CHECKING:  # nav.terrain imports trimesh, which swallows Ctrl-C in its imports:
    from nav.terrain import Terrain  # it is imported only where a terrain is built

# --------------------------------------------------------------------------- truth


@lru_cache(maxsize=8)
def build_terrain(spec: Any, bounds: tuple[float, float, float, float]) -> Terrain:
    """The world's ground mesh (a :class:`slam.kinds.drone.world.TerrainSpec` and the map bounds).

    Flat and hills meshes cover the bounds plus ``margin_m``; a mesh file is read as is.
    """
    from nav.terrain import Terrain

    m = spec.margin_m
    ext = (bounds[0] - m, bounds[1] + m, bounds[2] - m, bounds[3] + m)
    if spec.kind == "flat":
        return Terrain.flat(ext, spec.base_height_m)
    if spec.kind == "hills":
        return Terrain.hills(ext, spec.hill_centres, spec.hill_amplitude_m, spec.hill_width_m,
                             spec.base_height_m, spec.grid_spacing_m)
    return mesh_terrain(spec.mesh_path)


def mesh_terrain(path: str) -> Terrain:
    """The terrain of a mesh file; raises ``ValueError`` saying why a file is no usable
    mesh (unreadable, no triangles, non-finite or too many vertices)."""
    import trimesh

    from nav.terrain import Terrain

    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # whatever the mesh reader raises, the user's file is bad
        raise ValueError(f"cannot read as a mesh ({type(exc).__name__}: {exc})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ValueError("no triangle mesh in the file")
    vertices = np.asarray(mesh.vertices, dtype=float)
    if len(vertices) > limits.MAX_TERRAIN_VERTICES:
        raise ValueError(f"has {len(vertices)} vertices; at most "
                         f"{limits.MAX_TERRAIN_VERTICES} are allowed")
    if not np.all(np.isfinite(vertices)):
        raise ValueError("has non-finite vertex coordinates")
    tri = vertices[np.asarray(mesh.faces)][..., :2]  # bucket cells of the height lookup:
    size = np.ptp(tri.reshape(-1, 2), axis=0).max()  # at most ~4e6 of them
    cell = max(2.0 * float(np.median(np.ptp(tri, axis=1).max(axis=1))), size / 2000.0, 1e-6)
    return Terrain(mesh, bucket_m=cell)


def terrain_of(world) -> Terrain:
    """The terrain of ``world``; a mesh that does not cover the map raises ``WorldError``."""
    from worlds.schema import WorldError

    try:
        return build_terrain(world.terrain, tuple(world.map.bounds_m))
    except ValueError as exc:
        raise WorldError(world.source or world.name, "terrain.mesh_file", str(exc),
                         world.terrain.mesh_file) from None


def flight_plan(world) -> FlightPlan:
    """The :class:`~slam.kinds.drone.flight.FlightPlan` of a drone world."""
    veh = world.vehicle
    return FlightPlan(
        waypoints=tuple((float(x), float(y)) for x, y in world.map.waypoints),
        start_xy=tuple(map(float, veh.start_xy)),
        start_heading=float(veh.start_heading_rad),
        speed=veh.speed_mps,
        max_turn_rate=veh.max_turn_rate_rad_s,
        max_turn_accel=veh.max_turn_accel_rad_s2,
        steer_gain=veh.steer_gain_per_s,
        at_waypoint=veh.at_waypoint_m,
        loops=veh.loops,
        height_above_ground=veh.height_above_ground_m,
        altitude_smoothing_s=veh.altitude_smoothing_s,
        dt=world.imu.dt_s,
        drag_per_s=veh.drag_per_s,
    )


def nav_frame(world) -> NavFrame:
    imu = world.imu
    wie = earth_rate_enu(imu.latitude_rad) if imu.earth_rate else None
    return NavFrame(imu.dt_s, gravity_enu(imu.gravity_mps2), wie)


@lru_cache(maxsize=8)
def _truth(plan: FlightPlan, spec: Any, bounds: tuple, landmarks_xy: tuple, g: float,
           wie: tuple | None) -> tuple[Trajectory, Array]:
    terrain = build_terrain(spec, bounds)
    lm = np.array(landmarks_xy, dtype=float).reshape(-1, 2)
    z = terrain.height(lm)
    if not np.all(np.isfinite(z)):
        i = int(np.flatnonzero(~np.isfinite(z))[0])
        raise ValueError(f"landmark {i} {lm[i].tolist()} is outside the terrain mesh")
    traj = fly(plan, terrain.height, gravity_enu(g), None if wie is None else np.array(wie))
    return traj, np.column_stack([lm, z])


def truth_of(world) -> tuple[Trajectory, Array]:
    """``(trajectory, landmarks (N, 3))`` of ``world`` (deterministic; cached).

    Raises ``WorldError`` naming the key when the path cannot be flown or a landmark lies
    off the terrain.
    """
    from worlds.schema import WorldError

    terrain_of(world)  # mesh problems are reported against their key
    wie = nav_frame(world).earth_rate
    try:
        traj, lms = _truth(flight_plan(world), world.terrain, tuple(world.map.bounds_m),
                           tuple(map(tuple, world.map.landmarks.tolist())),
                           float(world.imu.gravity_mps2), None if wie is None else tuple(wie))
    except ValueError as exc:
        key = "map.landmarks" if "landmark" in str(exc) else "map.waypoints"
        raise WorldError(world.source or world.name, key, str(exc)) from None
    if traj.n_samples < world.samples_per_epoch:  # no sensor epoch: nothing to score
        raise WorldError(world.source or world.name, "map.waypoints",
                         f"the flight ends after {traj.n_samples} IMU samples, before the "
                         "first sensor epoch; are the waypoints all within at_waypoint_m "
                         "of the start?")
    if msg := empty_lap(traj, world.samples_per_epoch, world.imu.dt_s * world.samples_per_epoch):
        raise WorldError(world.source or world.name, "map.waypoints", msg)
    return traj, lms


def lap_epochs(loop_end_steps: Array, samples_per_epoch: int, n_samples: int) -> Array:
    """Sensor epochs in each lap: the epochs at IMU samples ``k · samples_per_epoch`` with
    ``end[i-1] < k · n <= end[i]`` (epoch 0, the prior, in lap 1)."""
    steps = np.arange(n_samples // samples_per_epoch + 1) * samples_per_epoch
    lap = np.searchsorted(np.asarray(loop_end_steps), steps, side="left")
    return np.bincount(lap, minlength=len(loop_end_steps))[: len(loop_end_steps)]


def empty_lap(traj: Trajectory, samples_per_epoch: int, period_s: float) -> str | None:
    """Why the flight is not ``loops`` laps (a lap with no sensor epoch: the per-lap errors
    of the summary would have nothing to average), or ``None``."""
    ends = np.asarray(traj.loop_end_steps)
    counts = lap_epochs(ends, samples_per_epoch, traj.n_samples)
    if counts.size and counts.min() > 0:
        return None
    i = int(np.argmin(counts))
    lasts = float(ends[i] - (ends[i - 1] if i else 0)) * traj.dt
    return (f"lap {i + 1} of {len(ends)} lasts {lasts:.3g} s and holds no sensor epoch "
            f"(period {period_s:g} s): a lap of the waypoints must take at least one sensor "
            "period (are they all within at_waypoint_m of each other?)")


