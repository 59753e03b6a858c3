"""One-line meanings of the ``planar-slam`` world keys (the world-file reference,
:mod:`worlds.reference`; the keys all kinds share are in :data:`worlds.reference.COMMON`)."""

DESCRIPTIONS: dict[str, str] = {
    "map.bounds_m": "the map's extent [xmin, xmax, ymin, ymax]; landmarks, waypoints and "
                    "the start lie inside",
    "map.file": 'a JSON map next to the world file: {"lm": [xs, ys], "wp": [xs, ys]}',
    "map.landmarks": "landmark positions (inline, or from the map file)",
    "map.waypoints": "the loop's waypoints, driven in order (at least 2)",
    "vehicle.speed_mps": "the car's constant speed",
    "vehicle.max_steer_deg": "steering-angle limit",
    "vehicle.steer_rate_deg_s": "steering-rate limit of the waypoint controller",
    "vehicle.wheelbase_m": "distance between the axles (bicycle model)",
    "vehicle.dt_s": "control step",
    "vehicle.at_waypoint_m": "a waypoint is reached within this distance",
    "vehicle.loops": "laps of the waypoint loop",
    "vehicle.start_xy_m": "start position (the filters' initial mean)",
    "vehicle.start_heading_deg": "start heading (default: towards the first waypoint)",
    "vehicle.initial_sigma_xy_m": "σ of the true start about start_xy_m (the filters' P0; "
                                  "0: known exactly)",
    "vehicle.initial_sigma_heading_deg": "σ of the true start heading (the filters' P0)",
    "sensor.max_range_m": "landmarks beyond this range are not seen",
    "sensor.period_steps": "control steps per range-bearing scan (one filter epoch)",
    "sensor.sigma_range_m": "range noise σ",
    "sensor.sigma_bearing_deg": "bearing noise σ",
    "sensor.front_half_plane": "see only landmarks ahead of the vehicle (|bearing| < 90°)",
    "noise.sigma_speed_mps": "σ of the speed the filters are given",
    "noise.sigma_steer_deg": "σ of the steering angle the filters are given",
    "filters.online": "also score iSAM2's current pose and marginal after every epoch (row "
                      "isam2, the online optimum; --online)",
    "filters.fixed_lags_s": "also score a fixed-lag smoother per lag in seconds (rows "
                            "fls-<lag>s; --fixed-lag S)",
}
