"""Truth of the spinning kind (:mod:`slam.kinds.spinning.truth`): eq. 6 against the
rotation matrix, eq. 7-8's roll, the Euler-rate relations, the drag calibration against
Table 2, and the blind-area detector on constructed attitudes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.kinds.spinning.truth import (
    Field,
    attitude_dcm,
    axial_field,
    axis_field_angle,
    blind_area,
    body_field,
    radial_blind,
    roll_from_field,
    trajectory,
)
from tests.slam.kinds.spinning.helpers import spinning_world

DEG = math.pi / 180.0
FIELD = Field(50986.1, -48.17 * DEG, 2.32 * DEG)  # Table 1


def _attitudes(n: int, seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return (rng.uniform(-1.4, 1.4, n), rng.uniform(-math.pi, math.pi, n),
            rng.uniform(0.0, 2 * math.pi, n))


def test_eq6_is_the_rotated_field() -> None:
    a, b, g = _attitudes(50)
    expected = np.einsum("nji,j->ni", attitude_dcm(a, b, g), FIELD.nav)  # C_nb^T B_n
    assert np.allclose(body_field(FIELD, a, b, g), expected, atol=1e-8)
    # the body axis is [cos a cos b, sin a, -cos a sin b] in NUE (the paper's Fig. 2)
    x_axis = attitude_dcm(a, b, g)[:, :, 0]
    assert np.allclose(x_axis, np.column_stack([np.cos(a) * np.cos(b), np.sin(a),
                                                -np.cos(a) * np.sin(b)]))


def test_roll_from_the_radial_components_inverts_eq6() -> None:
    a, b, g = _attitudes(200)
    ok = axis_field_angle(FIELD, a, b) > 5 * DEG
    field = body_field(FIELD, a, b, g)
    roll = roll_from_field(FIELD, a, b, field[:, 1], field[:, 2])
    err = np.angle(np.exp(1j * (roll - g)))
    assert np.abs(err[ok]).max() < 1e-9


def test_euler_rates_match_the_body_rate() -> None:
    """The re-derived eq. 2 (module docstring) against a numerical body rate."""
    a, b, g = 0.3, -0.2, 1.1
    ad, bd, gd, h = 0.01, 0.02, 3.0, 1e-7
    C0 = attitude_dcm(np.array(a), np.array(b), np.array(g))
    C1 = attitude_dcm(np.array(a + ad * h), np.array(b + bd * h), np.array(g + gd * h))
    W = (C0.T @ C1 - np.eye(3)) / h
    wx, wy, wz = W[2, 1], W[0, 2], W[1, 0]
    assert math.isclose(wy * math.sin(g) + wz * math.cos(g), ad, rel_tol=1e-5)
    assert math.isclose((wy * math.cos(g) - wz * math.sin(g)) / math.cos(a), bd, rel_tol=1e-5)
    assert math.isclose(wx - math.tan(a) * (wy * math.cos(g) - wz * math.sin(g)), gd,
                        rel_tol=1e-5)


def test_drag_calibration_meets_table_2() -> None:
    w = spinning_world()
    assert w.flight.drag_k_per_m is None  # calibrated
    f = trajectory(w.flight)
    assert f.flight_time_s == pytest.approx(87.5, rel=0.02)
    assert f.range_m == pytest.approx(27126.4, rel=0.02)
    assert f.apex_m == pytest.approx(9377.0, rel=0.02)
    # a given drag constant is used as given (and a drag-free flight is the vacuum one)
    g = trajectory(spinning_world(**{"flight.drag_k_per_m": 0.0,
                                     "flight.crosswind_mps": 0.0}).flight)
    assert g.range_m == pytest.approx(897.0**2 / 9.80665, rel=1e-6)


def test_blind_area_detector_on_constructed_attitudes() -> None:
    I, D = FIELD.inclination_rad, FIELD.declination_rad
    # the axis along the field line (either sense): radial field zero, inside
    along = np.array([I, -I]), np.array([D, D + math.pi])
    assert np.all(blind_area(FIELD, *along, 10 * DEG))
    assert np.allclose(axis_field_angle(FIELD, *along), 0.0, atol=1e-7)
    radial = body_field(FIELD, along[0], along[1], np.array([0.7, 2.0]))[:, 1:]
    assert np.abs(radial).max() < 1e-3
    assert np.allclose(axial_field(FIELD, along[0][:1], along[1][:1]), FIELD.intensity_nt)
    # the launch attitude (45 deg up, north) is far from it; 9 deg off the line is inside
    # a 10 deg threshold and outside an 8 deg one
    assert not blind_area(FIELD, np.array([45 * DEG]), np.array([0.0]), 10 * DEG)[0]
    off = np.array([I + 9 * DEG]), np.array([D])
    assert axis_field_angle(FIELD, *off)[0] == pytest.approx(9 * DEG, abs=1e-9)
    assert blind_area(FIELD, *off, 10 * DEG)[0] and not blind_area(FIELD, *off, 8 * DEG)[0]
    # the measured-radial detector says the same on noise-free readings
    a, b, g = _attitudes(300)
    mag = body_field(FIELD, a, b, g)
    for threshold in (10 * DEG, 40 * DEG):
        assert np.array_equal(radial_blind(FIELD, mag, threshold),
                              blind_area(FIELD, a, b, threshold))
