"""One-line meanings of the ``attitude`` (star-sensor) world keys (the world-file
reference, :mod:`worlds.reference`; shared keys in :data:`worlds.reference.COMMON`)."""

DESCRIPTIONS: dict[str, str] = {
    "duration_s": "length of each run",
    "satellite.orbit_height_km": "circular orbit height",
    "satellite.inclination_deg": "orbit inclination",
    "satellite.orbital_rate_rad_s": "orbital rate of the orbit (LVLH) frame",
    "satellite.initial_attitude_deg": "true initial [roll, pitch, yaw] (the paper's Z-X-Y "
                                      "sequence)",
    "satellite.initial_rate_deg_s": "body rate [x, y, z] relative to the orbit frame",
    "gyro.rate_hz": "gyro sample rate",
    "gyro.bias_deg_h": "true constant gyro drift [x, y, z] at t = 0",
    "gyro.bias_rw_deg_h_sqrt_h": "true gyro rate random walk",
    "gyro.arw_deg_sqrt_h": "true gyro angle random walk",
    "star_sensor.rate_hz": "star sensor rate (one filter update)",
    "star_sensor.sigma_arcsec": "true star sensor noise σ per axis",
    "star_sensor.mode": "measure a quaternion, or star directions",
    "star_sensor.n_stars": "vectors mode: stars observed per update",
    "star_sensor.directions": "vectors mode: navigation-frame star directions (default: "
                              "a built-in set)",
    "filters.initial_error_deg": "the estimate starts at the truth plus this "
                                 "[roll, pitch, yaw] error",
    "filters.initial_attitude_var_deg2": "prior attitude variance per axis",
    "filters.initial_bias_var_deg_h2": "prior gyro-bias variance per axis",
    "filters.arw_deg_sqrt_h": "gyro angle random walk the filters and the smoother assume",
    "filters.bias_rw_deg_h_sqrt_h": "gyro rate random walk the filters and the smoother assume",
    "filters.star_sigma_arcsec": "star sensor σ the filters and the smoother assume",
    "scoring.steady_state_from_s": "steady-state scores are over the epochs from this time on",
    "scoring.report_convergence": "report the time after which the error stays below 1′",
}
