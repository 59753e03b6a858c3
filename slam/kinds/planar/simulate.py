r"""Simulate a planar SLAM run in the manner of Tim Bailey's simulator.

The true vehicle is Bailey's car-like model driven at constant speed ``V`` by a steering
controller that turns towards the current waypoint:

* at step ``k`` (pose ``truth[k]``), while the current waypoint is within ``at_waypoint_m``
  it is ticked off and the next one becomes current; after the last waypoint the vehicle
  goes back to the first, until it has driven ``loops`` laps through the waypoint list.
  **The run ends at the step where the last waypoint of the last lap is reached** (Bailey's
  rule), so ``truth[-1]`` is within ``at_waypoint_m`` of the last waypoint and ``K`` follows
  from the path;
* otherwise the steer changes by ``wrap(bearing to waypoint - heading - G)``, limited to
  ``±steer_rate·dt`` per step, and ``G`` is limited to ``±max_steer``; then the vehicle
  moves for ``dt`` with the true controls ``[V, G]``.

The log's ``controls`` are the true controls plus ``N(0, diag(σV², σG²))`` (what a filter
sees).  Every ``period_steps`` steps (at ``k = p, 2p, ...``, after the move into ``k``) the
sensor sees every landmark within ``max_range_m`` and, if ``front_half_plane``, with a
positive body-frame ``x``; it reports range ``+ N(0, σR²)`` and bearing
``wrap(atan2(dy, dx) - φ + N(0, σB²))``.

Randomness comes only from the ``Generator`` passed in, drawn in a fixed order (start
offset, control noise, observation noise), so equal seeds give bit-identical logs.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from estimators import wrap_angle
from slam.kinds.planar.log import PlanarLog
from slam.kinds.planar.world import VehicleSpec, World
from worlds.schema import WorldError

TWO_PI = 2.0 * math.pi


def drive(world: World, start: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Drive the true vehicle from ``start`` through the waypoint loops.

    Returns ``truth`` ``(K + 1, 3)`` and the true steer angles ``(K,)`` (fresh arrays; the
    drive is deterministic, so a campaign whose start is exact drives once per process).
    Raises :class:`WorldError` if a waypoint is never reached (it lies inside the
    vehicle's turning circle, say).
    """
    wps = tuple(map(tuple, world.map.waypoints.tolist()))
    truth, steer = _drive(world.vehicle, wps, tuple(start), world.source or world.name)
    return truth.copy(), steer.copy()


@lru_cache(maxsize=8)
def _drive(veh: VehicleSpec, wps_t: tuple[tuple[float, float], ...],
           start: tuple[float, float, float], where: str) -> tuple[np.ndarray, np.ndarray]:
    wps = [list(w) for w in wps_t]
    n_wp = len(wps)
    vdt = veh.speed_mps * veh.dt_s
    wb = veh.wheelbase_m
    max_g, max_dg = veh.max_steer_rad, veh.steer_rate_rad_s * veh.dt_s
    reach2 = veh.at_waypoint_m**2

    # Generous step budget: 4x the polyline length (plus slack) at speed V.
    legs = np.diff(np.vstack([start[:2], wps]), axis=0)
    lap = float(np.hypot(*legs[1:].T).sum() + math.dist(wps[-1], wps[0]))
    budget = int(4.0 * (math.dist(start[:2], wps[0]) + veh.loops * lap) / vdt) + 10_000

    x, y, phi = (float(s) for s in start)
    xs, ys, phis, steers = [x], [y], [phi], []
    g = 0.0
    iwp, laps_left = 0, veh.loops
    wx, wy = wps[0]
    for _ in range(budget):
        while (wx - x) ** 2 + (wy - y) ** 2 < reach2:
            iwp += 1
            if iwp == n_wp:
                laps_left -= 1
                if laps_left == 0:
                    return np.column_stack([xs, ys, phis]), np.array(steers)
                iwp = 0
            wx, wy = wps[iwp]
        dg = wrap_angle(math.atan2(wy - y, wx - x) - phi - g)
        g += max(-max_dg, min(max_dg, dg))
        g = max(-max_g, min(max_g, g))
        x = x + vdt * math.cos(g + phi)
        y = y + vdt * math.sin(g + phi)
        phi = wrap_angle(phi + vdt * math.sin(g) / wb)
        xs.append(x)
        ys.append(y)
        phis.append(phi)
        steers.append(g)
    raise WorldError(
        where,
        "map.waypoints",
        f"the vehicle did not reach waypoint {iwp} within {budget} steps "
        "(inside its turning circle?)",
        wps[iwp],
    )


def observe(
    world: World, truth: np.ndarray, rng: np.random.Generator, noise_scale: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Range-bearing observations along ``truth``: ``(obs_step, obs_id, obs)``."""
    sen = world.sensor
    lm = world.map.landmarks
    steps = np.arange(sen.period_steps, truth.shape[0], sen.period_steps, dtype=np.int64)
    pose = truth[steps]
    dx = lm[None, :, 0] - pose[:, 0, None]
    dy = lm[None, :, 1] - pose[:, 1, None]
    d2 = dx * dx + dy * dy
    seen = d2 < sen.max_range_m**2
    if sen.front_half_plane:
        seen &= dx * np.cos(pose[:, 2, None]) + dy * np.sin(pose[:, 2, None]) > 0.0
    row, lid = np.nonzero(seen)  # row-major: sorted by step, then landmark id
    noise = rng.standard_normal((row.size, 2)) * (
        noise_scale * np.array([sen.sigma_range_m, sen.sigma_bearing_rad])
    )
    rng_m = np.sqrt(d2[row, lid]) + noise[:, 0]
    bearing = wrap_angle(np.arctan2(dy[row, lid], dx[row, lid]) - pose[row, 2] + noise[:, 1])
    return steps[row], lid.astype(np.int64), np.column_stack([rng_m, bearing])


def simulate_planar(
    world: World, rng: np.random.Generator, *, noise_scale: float = 1.0
) -> PlanarLog:
    """Simulate one run of ``world``: truth, noisy controls and observations.

    ``noise_scale`` multiplies every noise sigma actually applied (start offset, controls,
    observations); ``0`` gives a noise-free log.  The log's ``P0``, ``control_cov`` and
    ``obs_cov`` always state the world's nominal noise (what the filters are tuned for).
    """
    veh, noise, sen = world.vehicle, world.noise, world.sensor
    start = np.array(veh.start, dtype=float)
    sigma0 = np.array(veh.initial_pose_sigma, dtype=float)
    true_start = start + rng.standard_normal(3) * (noise_scale * sigma0)

    truth, steer = drive(world, (float(true_start[0]), float(true_start[1]), float(true_start[2])))
    k = steer.shape[0]
    if k < sen.period_steps:  # no scan, nothing to score: not a run
        raise WorldError(world.source or world.name, "map.waypoints",
                         f"the vehicle reaches the last waypoint after {k} control steps, "
                         f"before the first sensor scan (period_steps = {sen.period_steps}); "
                         "are the waypoints all within at_waypoint_m of the start?")
    true_controls = np.column_stack([np.full(k, veh.speed_mps), steer])
    sig_u = np.array([noise.sigma_speed_mps, noise.sigma_steer_rad])
    controls = true_controls + rng.standard_normal((k, 2)) * (noise_scale * sig_u)

    obs_step, obs_id, obs = observe(world, truth, rng, noise_scale)
    return PlanarLog(
        dt=float(veh.dt_s),
        wheelbase=float(veh.wheelbase_m),
        x0=start,
        P0=np.diag(sigma0**2),
        controls=controls,
        control_cov=np.diag(sig_u**2),
        obs_step=obs_step,
        obs_id=obs_id,
        obs=obs,
        obs_cov=np.diag([sen.sigma_range_m**2, sen.sigma_bearing_rad**2]),
        truth=truth,
        landmarks=np.array(world.map.landmarks, dtype=float),
    )
