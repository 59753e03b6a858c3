"""The ship's filters on exact data (:mod:`slam.kinds.ship.run`), and failures reported as
divergence.

Exact data: the gyro without noise or drift and vector readings ``C(q)ᵀR`` without noise;
the filters assume the bundled world's noises and start at the truth.  With a tight prior
every estimator stays on the truth (the sigma-point means are exact up to the second order
of the bias points' spread, ~1e-10 rad).  With the wide initial prior the MEKF and the
pseudo-observation filters still do - the symmetric points' quaternions sum to a multiple
of :math:`\\hat q`, so :math:`\\sum_i w_i G q_i = 0` - while the sigma-point filters with the
vector measurement leave it: their predicted :math:`\\sum_i w_i C(q_i)^\\top R` carries the
:math:`O(P)` term :math:`\\tfrac12\\sum_i w_i[\\delta_i\\times]^2 b`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from estimators import Transition
from nav.quaternion import qconj, qrotate
from nav.spaces import UnitQuaternion
from slam.kinds.ship.models import earth_rate_transition, treatment, vector_measurement
from slam.kinds.ship.run import estimators, initial_belief, run_filter
from slam.kinds.ship.simulate import ShipLog, simulate_ship
from slam.kinds.ship.world import ShipWorld
from tests.slam.kinds.ship.worlds import noise_free, ship_world

DEG = math.pi / 180.0


@pytest.fixture(scope="module")
def exact() -> tuple[ShipWorld, ShipLog, Transition]:
    """A 15 s noise-free log with exact vectors, and the nominal process model."""
    nominal = ship_world(15.0)
    w = ship_world(15.0, **noise_free(**{"filters.initial_error_deg": [0.0, 0.0, 0.0]}))
    log = simulate_ship(w, np.random.default_rng(31))
    body = qrotate(qconj(log.update_truth_q)[:, None, :], log.refs[None])
    log = dataclasses.replace(log, vectors=body)
    g = nominal.gyro
    trans = earth_rate_transition(log.samples_per_update, log.dt, g.arw_rad_sqrt_s,
                                  g.bias_rw_rad_s_sqrt_s, log.earth_rate)
    return w, log, trans


def _errors(w: ShipWorld, log: ShipLog, trans: Transition, P0: np.ndarray
            ) -> dict[str, float]:
    x0, _ = initial_belief(w, log)
    vec = vector_measurement(log)
    out = {}
    for name, t, main in estimators(w, [*w.filters.names]):
        s = run_filter(log, w.filters.make(name), treatment(t), x0, P0, trans, vec, main)
        assert not s.diverged, s.failure
        out[s.name] = float(np.linalg.norm(UnitQuaternion().local(s.means[:, :4],
                                                                  log.update_truth_q),
                                           axis=1).max())
    return out


def test_exact_data_with_a_tight_prior_every_estimator_stays_on_the_truth(exact) -> None:
    w, log, trans = exact
    P0 = np.diag([(1.0 / 60.0 * DEG) ** 2] * 3 + [(0.01 * DEG / 3600.0) ** 2] * 3)
    err = _errors(w, log, trans, P0)
    assert {"hommukf", "ukf", "cdkf", "srckf", "ekf", "ukf:additive", "ukf:manifold"} <= set(err)
    assert max(err.values()) < 1e-9, err


def test_exact_data_with_the_wide_prior(exact) -> None:
    w, log, trans = exact
    _, P0 = initial_belief(w, log)
    err = _errors(w, log, trans, P0)
    for name in ("hommukf", "ukf", "cdkf", "ukf:additive", "ekf"):
        assert err[name] < 1e-9, (name, err[name])
    for name in ("srckf", "ukf:manifold"):
        assert err[name] > 1e-7, (name, err[name])


def test_a_numerical_failure_ends_the_run_as_diverged(exact) -> None:
    w, log, trans = exact
    gyro = np.array(log.gyro)
    gyro[250] = np.nan
    bad = dataclasses.replace(log, gyro=gyro)
    x0, P0 = initial_belief(w, bad)
    s = run_filter(bad, w.filters.make("hommukf"), treatment("paper"), x0, P0, trans,
                   vector_measurement(bad))
    assert s.diverged and "finite" in (s.failure or "").lower()
    assert np.all(np.isfinite(s.means[:3])) and np.all(np.isnan(s.means[3:]))
