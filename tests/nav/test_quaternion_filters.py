"""Filters on the unit-quaternion space near a 180° attitude.

Left-multiplying every attitude and reference vector by a fixed rotation ``R0``
leaves the measurements unchanged and, with right-perturbation errors
(``q = q̂ ⊗ Exp(δ)``), leaves error covariances unchanged too.  So a filter run at an
attitude near 180° must equal the same run rotated next to the identity.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import Measurement, Noise, Transition, make_filter
from nav.quaternion import qconj, qexp, qlog, qmul, qto_dcm
from nav.spaces import UnitQuaternion

DT = 0.1
OMEGA = np.array([0.004, -0.003, 0.01])  # rad/s: crosses 180° about z after 2 s
REFS = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])  # navigation-frame reference vectors


def models(refs: np.ndarray):
    tr = Transition(lambda Q, u: qmul(Q, qexp(OMEGA * DT)),
                    Noise.from_cov(np.eye(3) * 1e-5))

    def h(Q):  # body-frame directions b_j = C(q)ᵀ r_j, stacked
        C = qto_dcm(Q)
        return np.concatenate([np.einsum("...ji,j->...i", C, r) for r in refs], axis=-1)

    return tr, Measurement(h, Noise.from_cov(np.eye(6) * 1e-4))


def run(name: str, R0: np.ndarray, seed: int = 0):
    q_true = qexp(np.array([0.0, 0.0, np.pi - 0.02]))  # 178.9° about z
    refs = np.einsum("ij,kj->ki", qto_dcm(R0), REFS)
    tr, me = models(refs)
    rng = np.random.default_rng(seed)
    f = make_filter(name)
    b = f.init(qmul(R0, qmul(q_true, qexp([0.05, -0.04, 0.1]))), UnitQuaternion(),
               cov=np.eye(3) * 0.02)
    q_true = qmul(R0, q_true)
    means, covs, w_true = [], [], []
    for _ in range(40):
        q_true = qmul(q_true, qexp(OMEGA * DT))
        w_true.append(qmul(qconj(R0), q_true)[0])
        z = me.h(q_true[None])[0] + 1e-2 * rng.standard_normal(6)
        b, _ = f.update(f.predict(b, tr), me, z)
        means.append(b.mean)
        covs.append(b.cov)
    return np.array(means), np.array(covs), q_true, np.array(w_true)


@pytest.mark.parametrize("name", ["ukf", "ckf", "srckf", "srukf", "srcdkf", "ekf"])
def test_attitude_filter_near_pi_matches_the_rotated_run(name):
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    R0 = qconj(qexp(np.array([0.0, 0.0, np.pi - 0.02])))  # brings the truth to ~identity
    m_pi, c_pi, truth_pi, w = run(name, identity)
    m_id, c_id, _, _ = run(name, R0)
    assert np.degrees(np.linalg.norm(qlog(truth_pi))) > 178.0  # really near 180°
    assert w.min() < 0.0 < w.max()  # the true quaternion crossed w = 0 (exactly 180°)
    # the estimate tracks the truth near 180°
    assert np.linalg.norm(qlog(qmul(qconj(m_pi[-1]), truth_pi))) < 0.02
    # and equals the rotated run: R0 ⊗ q̂(π) = q̂(identity), same covariances
    diff = qlog(qmul(qconj(qmul(R0, m_pi)), m_id))
    assert np.abs(diff).max() < 1e-9
    np.testing.assert_allclose(c_pi, c_id, rtol=1e-7, atol=1e-14)


def test_quaternion_mean_never_adds_quaternions():
    """Points straddling the q / -q sign flip average to the right attitude."""
    space = UnitQuaternion()
    q0 = qexp(np.array([0.0, np.pi - 1e-3, 0.0]))
    deltas = np.array([[0.0, 0.01, 0.0], [0.0, -0.01, 0.0]])
    pts = space.retract(q0, deltas)
    pts[1] = -pts[1]  # same rotation, other hemisphere
    mean = space.mean(pts, np.array([0.5, 0.5]))
    assert np.linalg.norm(space.local(q0, mean)) < 1e-12
    # the additive average of these points would be near zero
    assert np.linalg.norm(pts.mean(axis=0)) < 0.02
