"""The ship's GTSAM AHRS smoother (:mod:`slam.kinds.ship.reference`): exact data are
recovered (from the truth and from the 15° initial error), and its marginals pass a χ²
NEES test (and fail it when the smoother is told the vectors are 5× more precise than
they are)."""

from __future__ import annotations

import dataclasses

import numpy as np

from nav.quaternion import qconj, qrotate
from nav.spaces import UnitQuaternion
from slam.kinds.ship.reference import smooth_ship
from slam.kinds.ship.run import initial_belief
from slam.kinds.ship.scoring import score
from slam.kinds.ship.simulate import simulate_ship
from slam.scoring import anees_band, per_epoch_anees
from tests.slam.kinds.ship.worlds import noise_free, ship_world


def test_the_smoother_recovers_exact_data() -> None:
    """From the truth: to the AHRS factor's first-order Earth-rate term (< 0.5″).  From the
    15° initial error (dead reckoning from it): to the prior's linear-Gaussian pull,
    ~ error · σ_data²/σ_prior² ≈ 0.26 rad · (0.0048/0.26)² ≈ 9e-5 rad in yaw here."""
    w = ship_world(20.0, **noise_free())
    log = simulate_ship(w, np.random.default_rng(41))
    body = qrotate(qconj(log.update_truth_q)[:, None, :], log.refs[None])
    log = dataclasses.replace(log, vectors=body)
    g = ship_world(20.0).gyro  # the nominal noises
    for start, bound in (([0.0, 0.0, 0.0], 2e-6), ([2.0, 4.0, 15.0], 1.5e-4)):
        x0, P0 = initial_belief(ship_world(20.0, **{"filters.initial_error_deg": start}), log)
        s = smooth_ship(log, x0, P0, g.arw_rad_sqrt_s, g.bias_rw_rad_s_sqrt_s, marginals=False)
        err = np.linalg.norm(UnitQuaternion().local(s.means[:, :4], log.update_truth_q), axis=1)
        assert err.max() < bound, (start, err.max())


def test_smoother_marginals_pass_a_chi_square_nees_test() -> None:
    """Run-averaged attitude NEES / 3 (time-averaged over a 10 s window, whose epochs are
    strongly correlated, so it is held to the band of one epoch) over 20 runs; then 5 runs
    with the vector noises understated 5×, which must land far above the band."""
    w = ship_world(10.0)
    g = w.gyro

    def nees(runs: range, factor: float) -> float:
        out = []
        for r in runs:
            log = simulate_ship(w, np.random.default_rng(100 + r))
            x0, P0 = initial_belief(w, log)
            told = dataclasses.replace(log, sigmas=log.sigmas * factor)
            s = smooth_ship(told, x0, P0, g.arw_rad_sqrt_s, g.bias_rw_rad_s_sqrt_s)
            out.append(score(s, log, 1.0).nees3)
        return float(np.mean(per_epoch_anees(np.stack(out), 3)))

    lo, hi = anees_band(20, 3)
    assert lo < nees(range(20), 1.0) < hi
    assert nees(range(5), 0.2) > 3.0 * anees_band(5, 3)[1]
