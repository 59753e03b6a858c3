"""Property tests of the rotation library (:mod:`nav.quaternion`, :mod:`nav.euler`,
:mod:`nav.spaces`)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from estimators.spaces import Space
from nav import (
    UnitQuaternion,
    dcm_nb_from_paper,
    dcm_to_q,
    dcm_to_rotvec,
    euler_zxy_to_q,
    euler_zyx_to_q,
    omega_matrix,
    q_from_paper,
    q_to_euler_zxy,
    q_to_euler_zyx,
    q_to_paper,
    qconj,
    qexp,
    qlog,
    qmul,
    qnormalize,
    qpropagate,
    qrotate,
    qto_dcm,
    rotvec_to_dcm,
    skew,
)

PI = np.pi
FAST = settings(max_examples=60, deadline=None)
SLOW = settings(max_examples=15, deadline=None)
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])

# ----------------------------------------------------------------------------- strategies


def _batch(n: int, lo: float, hi: float, max_batch: int = 6) -> st.SearchStrategy:
    return hnp.arrays(
        np.float64,
        st.tuples(st.integers(1, max_batch), st.just(n)),
        elements=st.floats(lo, hi, allow_nan=False, allow_subnormal=False),
    )


def _rows_norm_above(a: np.ndarray, r: float) -> bool:
    return bool(np.all(np.linalg.norm(a, axis=-1) > r))


unit_quats = _batch(4, -1, 1).filter(lambda a: _rows_norm_above(a, 0.1)).map(qnormalize)
unit_axes = _batch(3, -1, 1).filter(lambda a: _rows_norm_above(a, 0.1)).map(
    lambda a: a / np.linalg.norm(a, axis=-1, keepdims=True))
vectors = _batch(3, -10, 10)
# |component| <= 1.8 gives |rotvec| <= 3.12 < π
rotvecs = _batch(3, -1.8, 1.8)


def same_rotation(p: np.ndarray, q: np.ndarray, atol: float) -> bool:
    """``p`` equals ``q`` or ``-q`` row by row."""
    d = np.minimum(np.abs(p - q).max(axis=-1), np.abs(p + q).max(axis=-1))
    return bool(np.all(d <= atol))


def wrapped_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a - b + PI) % (2 * PI) - PI


@pytest.fixture(autouse=True)
def _raise_on_fp_warnings():
    """No division by zero / invalid operations anywhere (e.g. at zero angle)."""
    with np.errstate(divide="raise", invalid="raise", over="raise", under="ignore"):
        yield


# ------------------------------------------------------------------------ exp / log


@FAST
@given(rotvecs)
def test_exp_log_round_trip(r):
    q = qexp(r)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-15)
    np.testing.assert_allclose(qlog(q), r, atol=1e-13)
    # q and -q have the same log
    np.testing.assert_allclose(qlog(-q), r, atol=1e-13)


@FAST
@given(unit_axes, st.floats(1e-12, 1e-5))
def test_exp_log_small_angles(axis, angle):
    r = angle * axis
    q = qexp(r)
    # relative accuracy of the vector part against the direct (accurate) formula
    # errors relative to the angle (components may be subnormal)
    np.testing.assert_allclose(q[:, 1:], (np.sin(angle / 2) / angle) * r, rtol=0,
                               atol=4e-16 * angle)
    np.testing.assert_allclose(qlog(q), r, rtol=0, atol=1e-15 * angle)


def test_exp_log_at_zero_and_series_switch():
    np.testing.assert_array_equal(qexp(np.zeros(3)), IDENTITY)
    np.testing.assert_array_equal(qlog(IDENTITY), np.zeros(3))
    np.testing.assert_array_equal(qlog(-IDENTITY), np.zeros(3))
    # both branches agree across the 1e-4 switch
    axis = np.array([0.6, -0.8, 0.0])
    angles = 1e-4 * (1.0 + np.array([-1e-12, 0.0, 1e-12]))[:, None]
    q = qexp(angles * axis)
    np.testing.assert_allclose(q[:, 1:], np.sin(angles / 2) * axis, rtol=1e-15)
    np.testing.assert_allclose(qlog(q), angles * axis, rtol=1e-15)


@FAST
@given(unit_axes, st.floats(PI - 1e-9, PI))
def test_exp_log_near_pi(axis, angle):
    r = angle * axis
    out = qlog(qexp(r))
    assert np.all(np.linalg.norm(out, axis=-1) <= PI * (1 + 4e-16))
    # near π the rotation vector is r or (for |r| ~ π) the equivalent -r
    close = np.abs(out - r).max(axis=-1) <= 1e-12
    flipped = np.abs(out + r).max(axis=-1) <= 1e-12
    assert np.all(close | flipped)
    assert same_rotation(qexp(out), qexp(r), 1e-15)


@FAST
@given(unit_quats)
def test_log_is_continuous_representative(q):
    r = qlog(q)
    assert np.all(np.linalg.norm(r, axis=-1) <= PI + 1e-15)
    assert same_rotation(qexp(r), q, 1e-15)
    # -q gives the same vector, except at exactly π (w = 0) where ±r are both valid
    r_neg = qlog(-q)
    exact_pi = q[:, 0] == 0.0
    np.testing.assert_allclose(r_neg[~exact_pi], r[~exact_pi], atol=1e-15)
    np.testing.assert_allclose(np.abs(r_neg[exact_pi]), np.abs(r[exact_pi]), atol=1e-15)


# ---------------------------------------------------------------- products, DCMs


@FAST
@given(unit_quats, unit_quats, unit_quats)
def test_qmul_matches_dcm_product(p, q, s):
    n = min(len(p), len(q), len(s))
    p, q, s = p[:n], q[:n], s[:n]
    np.testing.assert_allclose(qto_dcm(qmul(p, q)), qto_dcm(p) @ qto_dcm(q), atol=1e-14)
    np.testing.assert_allclose(qmul(qmul(p, q), s), qmul(p, qmul(q, s)), atol=1e-15)
    np.testing.assert_allclose(qmul(q, qconj(q)), np.broadcast_to(IDENTITY, q.shape),
                               atol=1e-15)


@FAST
@given(unit_quats, vectors)
def test_qrotate_matches_dcm(q, v):
    n = min(len(q), len(v))
    q, v = q[:n], v[:n]
    C = qto_dcm(q)
    expected = np.einsum("...ij,...j->...i", C, v)
    np.testing.assert_allclose(qrotate(q, v), expected, atol=1e-13)
    sandwich = qmul(qmul(q, np.concatenate([np.zeros((n, 1)), v], -1)), qconj(q))
    np.testing.assert_allclose(sandwich[:, 0], 0.0, atol=1e-13)
    np.testing.assert_allclose(sandwich[:, 1:], expected, atol=1e-13)
    np.testing.assert_allclose(C @ np.swapaxes(C, -1, -2), np.broadcast_to(np.eye(3), C.shape),
                               atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(C), 1.0, atol=1e-14)


@FAST
@given(vectors, vectors)
def test_skew_is_cross(a, b):
    n = min(len(a), len(b))
    a, b = a[:n], b[:n]
    np.testing.assert_allclose(np.einsum("...ij,...j->...i", skew(a), b), np.cross(a, b),
                               atol=1e-12)


@FAST
@given(unit_quats)
def test_dcm_to_q_round_trip(q):
    out = dcm_to_q(qto_dcm(q))
    assert np.all(out[:, 0] >= 0.0)
    assert same_rotation(out, q, 1e-15 * 4)


@FAST
@given(unit_axes, st.floats(PI - 1e-6, PI))
def test_dcm_to_q_near_pi(axis, angle):
    q = qexp(angle * axis)  # w ~ 1e-7 .. 0
    out = dcm_to_q(qto_dcm(q))
    assert same_rotation(out, q, 1e-15 * 4)
    r = dcm_to_rotvec(rotvec_to_dcm(angle * axis))
    assert np.all(np.abs(np.abs(np.einsum("...i,...i", r, axis)) - angle) <= 1e-14)


def test_dcm_to_q_exact_half_turns():
    C = np.array([np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]),
                  np.diag([-1.0, -1.0, 1.0]), np.eye(3)])
    expected = np.array([[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [1, 0, 0, 0]], float)
    np.testing.assert_array_equal(dcm_to_q(C), expected)


@FAST
@given(rotvecs)
def test_rotvec_dcm_round_trip(r):
    np.testing.assert_allclose(dcm_to_rotvec(rotvec_to_dcm(r)), r, atol=1e-13)


# ------------------------------------------------------------------------- scipy


@FAST
@given(unit_quats, unit_quats, rotvecs)
def test_agrees_with_scipy(p, q, r):
    n = min(len(p), len(q))
    p, q = p[:n], q[:n]
    Rp = Rotation.from_quat(p, scalar_first=True)
    Rq = Rotation.from_quat(q, scalar_first=True)
    np.testing.assert_allclose(qto_dcm(p), Rp.as_matrix(), atol=1e-15)
    assert same_rotation(qmul(p, q), (Rp * Rq).as_quat(scalar_first=True), 1e-15)
    assert same_rotation(dcm_to_q(Rp.as_matrix()), p, 4e-15)
    assert same_rotation(qexp(r), Rotation.from_rotvec(r).as_quat(scalar_first=True), 1e-15)
    # away from π scipy's rotation vector is the same representative
    q_r = qexp(r)
    np.testing.assert_allclose(qlog(q_r), Rotation.from_quat(q_r, scalar_first=True).as_rotvec(),
                               atol=1e-13)


roll_yaw = st.floats(-PI + 1e-6, PI - 1e-6)
middle = st.floats(-PI / 2 + 0.05, PI / 2 - 0.05)


@FAST
@given(roll_yaw, middle, roll_yaw)
def test_euler_zyx_round_trip_and_scipy(roll, pitch, yaw):
    q = euler_zyx_to_q(roll, pitch, yaw)
    R = Rotation.from_euler("ZYX", [yaw, pitch, roll])
    assert same_rotation(q[None], R.as_quat(scalar_first=True)[None], 1e-15)
    angles = q_to_euler_zyx(q)
    np.testing.assert_allclose(wrapped_diff(angles, np.array([roll, pitch, yaw])), 0.0,
                               atol=1e-13)
    np.testing.assert_allclose(wrapped_diff(angles, R.as_euler("ZYX")[::-1]), 0.0, atol=1e-12)


@FAST
@given(roll_yaw, middle, roll_yaw)
def test_euler_zxy_round_trip_and_scipy(roll, pitch, yaw):
    # paper's sequence: roll α is the middle (X) angle, pitch β the last (Y)
    roll, pitch = pitch, roll
    q = euler_zxy_to_q(roll, pitch, yaw)
    R = Rotation.from_euler("ZXY", [yaw, roll, pitch])
    assert same_rotation(q[None], R.as_quat(scalar_first=True)[None], 1e-15)
    C = qto_dcm(q)
    Rz, Rx, Ry = (Rotation.from_euler(ax, a).as_matrix() for ax, a in
                  (("z", yaw), ("x", roll), ("y", pitch)))
    np.testing.assert_allclose(C, Rz @ Rx @ Ry, atol=1e-15)
    angles = q_to_euler_zxy(q)
    np.testing.assert_allclose(wrapped_diff(angles, np.array([roll, pitch, yaw])), 0.0,
                               atol=1e-13)
    yaw_s, roll_s, pitch_s = R.as_euler("ZXY")
    np.testing.assert_allclose(wrapped_diff(angles, np.array([roll_s, pitch_s, yaw_s])), 0.0,
                               atol=1e-12)


@FAST
@given(unit_quats)
def test_euler_reconstructs_any_rotation(q):
    cases = ((q_to_euler_zyx, euler_zyx_to_q, 1), (q_to_euler_zxy, euler_zxy_to_q, 0))
    for to_euler, to_q, mid in cases:
        a = to_euler(q)
        assert np.all(np.abs(a) <= PI)
        back = to_q(a[:, 0], a[:, 1], a[:, 2])
        # within ~3e-10 rad of gimbal lock the last angle is zeroed (GIMBAL_LOCK_TOL),
        # which costs up to ~1e-9 in the reconstruction; elsewhere it is exact
        near_lock = PI / 2 - np.abs(a[:, mid]) < 1e-8
        assert same_rotation(back[~near_lock], q[~near_lock], 1e-14)
        assert same_rotation(back[near_lock], q[near_lock], 1e-9)
        np.testing.assert_allclose(wrapped_diff(to_euler(-q), a), 0.0, atol=1e-14)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_euler_gimbal_lock(sign):
    q = euler_zyx_to_q(0.3, sign * PI / 2, -1.1)
    roll, pitch, yaw = q_to_euler_zyx(q)
    assert roll == 0.0 and pitch == pytest.approx(sign * PI / 2, abs=1e-15)
    assert same_rotation(euler_zyx_to_q(roll, pitch, yaw)[None], q[None], 1e-15)
    q = euler_zxy_to_q(sign * PI / 2, 0.3, -1.1)
    roll, pitch, yaw = q_to_euler_zxy(q)
    assert pitch == 0.0 and roll == pytest.approx(sign * PI / 2, abs=1e-15)
    assert same_rotation(euler_zxy_to_q(roll, pitch, yaw)[None], q[None], 1e-15)


def test_euler_broadcasts():
    roll = np.zeros((2, 1))
    yaw = np.linspace(-1, 1, 5)
    assert euler_zyx_to_q(roll, 0.1, yaw).shape == (2, 5, 4)
    assert q_to_euler_zxy(np.ones((2, 5, 4))).shape == (2, 5, 3)


# -------------------------------------------------------------------- seed paper


@FAST
@given(unit_quats)
def test_paper_dcm_pattern_is_transpose_of_ours(q):
    """[Wang SRCKF-SLAM] eq. (5): its C_n^b in [q1 q2 q3 q4] equals qto_dcm(q).T elementwise."""
    q1, q2, q3, q4 = np.moveaxis(q_to_paper(q), -1, 0)
    C_n_b = np.stack([
        np.stack([q1**2 + q2**2 - q3**2 - q4**2, 2 * (q2 * q3 + q1 * q4),
                  2 * (q2 * q4 - q1 * q3)], -1),
        np.stack([2 * (q2 * q3 - q1 * q4), q1**2 - q2**2 + q3**2 - q4**2,
                  2 * (q3 * q4 + q1 * q2)], -1),
        np.stack([2 * (q2 * q4 + q1 * q3), 2 * (q3 * q4 - q1 * q2),
                  q1**2 - q2**2 - q3**2 + q4**2], -1),
    ], -2)
    np.testing.assert_allclose(C_n_b, np.swapaxes(qto_dcm(q), -1, -2), atol=1e-15)
    # hence the paper's quaternion is q_nb component for component
    np.testing.assert_array_equal(q_from_paper(q_to_paper(q)), q)
    np.testing.assert_array_equal(q_from_paper(q), q)
    np.testing.assert_allclose(dcm_nb_from_paper(C_n_b), qto_dcm(q_from_paper(q)), atol=1e-15)


def test_paper_conversions_copy():
    q = np.array([1.0, 0.0, 0.0, 0.0])
    out = q_from_paper(q)
    out[0] = 5.0
    assert q[0] == 1.0


# ------------------------------------------------------------------- propagation


def _kinematics(omega_of_t):
    def f(t, q):
        return 0.5 * omega_matrix(omega_of_t(t)) @ q
    return f


@SLOW
@given(unit_quats, _batch(3, -5, 5, max_batch=1), st.floats(1e-4, 0.5))
def test_qpropagate_constant_rate_matches_ode(q, omega, dt):
    q0, w = q[0], omega[0]
    sol = solve_ivp(_kinematics(lambda t: w), (0.0, dt), q0, method="DOP853",
                    rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(qpropagate(q0, w, dt), sol.y[:, -1], atol=1e-10)
    # the paper's 4x4 form exp(½ Ω dt) q
    np.testing.assert_allclose(qpropagate(q0, w, dt), expm(0.5 * omega_matrix(w) * dt) @ q0,
                               atol=1e-14)


def test_qpropagate_zero_and_tiny_rate():
    q = qnormalize(np.array([0.3, -0.2, 0.9, 0.1]))
    np.testing.assert_allclose(qpropagate(q, np.zeros(3), 0.01), q, atol=1e-16)
    w = np.array([1e-14, -2e-14, 3e-15])
    np.testing.assert_allclose(qpropagate(q, w, 0.01), qmul(q, qexp(w * 0.01)), atol=0)


def test_qpropagate_broadcasts():
    q = np.broadcast_to(IDENTITY, (4, 1, 4))
    w = np.ones((1, 3, 3))
    dt = np.full((4, 3), 0.1)
    assert qpropagate(q, w, dt).shape == (4, 3, 4)
    assert qpropagate(q, w, 0.1).shape == (4, 3, 4)


@settings(max_examples=4, deadline=None)
@given(unit_quats)
def test_qpropagate_many_steps_slowly_varying_rate(q):
    def omega(t):
        return np.array([0.3 * np.sin(0.5 * t), 0.2 * np.cos(0.3 * t), 0.1 + 0.05 * t])

    q0, T, n = q[0], 1.0, 1000
    dt = T / n
    t_mid = (np.arange(n) + 0.5) * dt
    w_mid = np.stack([omega(t) for t in t_mid])
    qk = q0
    for k in range(n):
        qk = qpropagate(qk, w_mid[k], dt)
    sol = solve_ivp(_kinematics(omega), (0.0, T), q0, method="DOP853", rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(qk, sol.y[:, -1], atol=1e-8)


# ---------------------------------------------------------------- UnitQuaternion

SPACE = UnitQuaternion()


def test_unit_quaternion_is_a_space():
    assert isinstance(SPACE, Space)
    assert (SPACE.ambient_dim, SPACE.dim) == (4, 3)


@FAST
@given(unit_quats, _batch(3, -1.8, 1.8))
def test_local_inverts_retract(x, delta):
    n = min(len(x), len(delta))
    x, delta = x[:n], delta[:n]
    y = SPACE.retract(x, delta)
    np.testing.assert_allclose(np.linalg.norm(y, axis=-1), 1.0, atol=1e-15)
    np.testing.assert_allclose(SPACE.local(x, y), delta, atol=1e-13)
    np.testing.assert_allclose(SPACE.local(x, -y), delta, atol=1e-13)
    np.testing.assert_allclose(SPACE.local(x, x), 0.0, atol=1e-15)


@FAST
@given(unit_quats, _batch(3, -0.6, 0.6, max_batch=4), st.floats(-2.0, 0.5))
def test_mean_of_symmetric_set_is_centre(q, deltas, w0):
    q0 = q[0]
    k = len(deltas)
    pts = SPACE.retract(q0, np.concatenate([np.zeros((1, 3)), deltas, -deltas]))
    w = np.concatenate([[w0], np.full(2 * k, (1.0 - w0) / (2 * k))])
    m = SPACE.mean(pts, w)
    np.testing.assert_allclose(SPACE.local(q0, m), 0.0, atol=1e-12)
    # without the centre point: starts off-centre, must still converge to q0
    m = SPACE.mean(pts[1:], np.full(2 * k, 1.0 / (2 * k)))
    np.testing.assert_allclose(SPACE.local(q0, m), 0.0, atol=1e-12)


@FAST
@given(unit_quats, _batch(3, -0.8, 0.8, max_batch=7), st.data())
def test_mean_invariant_to_sign_flips(q, deltas, data):
    m = len(deltas)
    pts = SPACE.retract(q[0], deltas)
    raw = np.array(data.draw(st.lists(st.floats(0.05, 1.0), min_size=m, max_size=m)))
    w = raw / raw.sum()
    flips = np.array(data.draw(st.lists(st.booleans(), min_size=m, max_size=m)))
    flipped = np.where(flips[:, None], -pts, pts)
    m1, m2 = SPACE.mean(pts, w), SPACE.mean(flipped, w)
    np.testing.assert_allclose(SPACE.local(m1, m2), 0.0, atol=1e-12)
    # the mean is a stationary point: weighted local residuals vanish
    np.testing.assert_allclose(w @ SPACE.local(m1, pts), 0.0, atol=1e-12)


@FAST
@given(unit_quats, _batch(3, -5e-4, 5e-4, max_batch=8), st.data())
def test_mean_of_tight_cloud_matches_chordal_mean(q, deltas, data):
    m = len(deltas)
    pts = SPACE.retract(q[0], deltas)
    raw = np.array(data.draw(st.lists(st.floats(0.05, 1.0), min_size=m, max_size=m)))
    w = raw / raw.sum()
    _, vecs = np.linalg.eigh(np.einsum("i,ij,ik->jk", w, pts, pts))
    chordal = vecs[:, -1]
    assert same_rotation(SPACE.mean(pts, w)[None], chordal[None], 1e-9)


def test_mean_with_large_cancelling_weights():
    """Unscented weights with α = 1e-3 (sum|w| ~ 2e6) still converge to the centre."""
    n, alpha = 3, 1e-3
    lam = alpha**2 * n - n
    S = np.sqrt(n + lam) * np.diag([0.8, 0.5, 0.3])
    q0 = qnormalize(np.array([0.2, 0.5, -0.4, 0.7]))
    pts = SPACE.retract(q0, np.concatenate([np.zeros((1, 3)), S, -S]))
    w = np.full(2 * n + 1, 1.0 / (2 * (n + lam)))
    w[0] = lam / (n + lam)
    m = SPACE.mean(pts, w)
    np.testing.assert_allclose(SPACE.local(q0, m), 0.0, atol=1e-9)


def test_mean_ties_start_at_first_and_failure_raises():
    q0 = qnormalize(np.array([0.9, 0.1, -0.3, 0.2]))
    pts = SPACE.retract(q0, np.array([[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]]))
    # an asymmetric wide cloud: the chordal start is O(spread³) off, one step is not enough
    wide = SPACE.retract(q0, np.array([[0.9, 0.0, 0.0], [-0.3, 0.8, 0.0], [0.0, 0.0, -1.0]]))
    with pytest.raises(ArithmeticError, match="did not converge"):
        UnitQuaternion(max_iter=1).mean(wide, np.array([0.2, 0.3, 0.5]))
    UnitQuaternion().mean(wide, np.array([0.2, 0.3, 0.5]))  # converges with iterations
    m = UnitQuaternion().mean(pts, np.array([0.5, 0.5]))
    assert np.sign(m @ pts[0]) == 1.0  # on the side of the first of the tied points
    np.testing.assert_allclose(SPACE.local(q0, m), 0.0, atol=1e-13)


def test_space_broadcasting_shapes():
    rng = np.random.default_rng(7)
    x = qnormalize(rng.normal(size=(5, 1, 4)))
    delta = 0.3 * rng.normal(size=(1, 7, 3))
    y = SPACE.retract(x, delta)
    assert y.shape == (5, 7, 4)
    assert SPACE.local(x, y).shape == (5, 7, 3)
    np.testing.assert_allclose(SPACE.local(x, y), np.broadcast_to(delta, (5, 7, 3)), atol=1e-14)

    pts = SPACE.retract(x[:, :, None, :], 0.2 * rng.normal(size=(5, 3, 6, 3)))  # (5, 3, 6, 4)
    w = rng.uniform(0.1, 1.0, size=6)
    w /= w.sum()
    batched = SPACE.mean(pts, w)
    assert batched.shape == (5, 3, 4)
    for i in range(5):
        for j in range(3):
            assert same_rotation(batched[i, j][None], SPACE.mean(pts[i, j], w)[None], 1e-14)
    w_b = np.broadcast_to(w, (5, 1, 6))
    np.testing.assert_allclose(SPACE.mean(pts, w_b), batched, atol=0)
    with pytest.raises(ValueError):
        SPACE.mean(pts, w[:5])


def test_inputs_are_not_mutated():
    rng = np.random.default_rng(3)
    q = qnormalize(rng.normal(size=(4, 4)))
    q[0] *= -1
    v = rng.normal(size=(4, 3))
    C = qto_dcm(q)
    saved = (q.copy(), v.copy(), C.copy())
    for f, args in [(qmul, (q, q)), (qconj, (q,)), (qnormalize, (q,)), (qexp, (v,)),
                    (qlog, (q,)), (qrotate, (q, v)), (qto_dcm, (q,)), (dcm_to_q, (C,)),
                    (qpropagate, (q, v, 0.1)), (q_to_euler_zyx, (q,)), (q_to_euler_zxy, (q,)),
                    (q_from_paper, (q,)), (dcm_nb_from_paper, (C,)), (skew, (v,)),
                    (SPACE.retract, (q, v)), (SPACE.local, (q, q)),
                    (SPACE.mean, (q, np.full(4, 0.25)))]:
        f(*args)
    for a, b in zip((q, v, C), saved, strict=True):
        np.testing.assert_array_equal(a, b)

