r"""Truth of the spinning projectile: a point mass with drag and gravity, its attitude, and
the geomagnetic field it flies through ([Spin SR-CH∞KF] §2, Tables 1-2).

Frames and angles (the paper's Fig. 2)
--------------------------------------
Navigation frame North-Up-East (NUE).  The body frame starts coincident with it and is
turned by the yaw :math:`\beta` about the up axis, then the pitch :math:`\alpha` about the
new z axis, then the roll :math:`\gamma` about the body x axis (the projectile's axis):

.. math::

    C_{nb} = R_y(\beta)\, R_z(\alpha)\, R_x(\gamma),\qquad
    x_b = [\cos\alpha\cos\beta,\ \sin\alpha,\ -\cos\alpha\sin\beta]^\top_{NUE}.

So a positive yaw turns the nose from north towards west, as the paper's right-hand rule
about the up axis (its declination is positive "north by west" for the same reason).

Geomagnetic field ([Spin SR-CH∞KF] eq. 4, Table 1) and its body components (eq. 6)
-------------------------------------------------------------------------------------
.. math::

    B_n = B\,[\cos D\cos I,\ \sin I,\ -\sin D\cos I]^\top,\qquad b = C_{nb}^\top B_n,

    b_x = B\cos I\cos\alpha\cos(D-\beta) + B\sin I\sin\alpha ,

    b_y = P\cos\gamma - Q\sin\gamma,\quad b_z = -P\sin\gamma - Q\cos\gamma,

    P = B(\sin I\cos\alpha - \cos I\sin\alpha\cos(D-\beta)),\quad Q = B\cos I\sin(D-\beta),

which is eq. 6 regrouped (checked against :math:`C_{nb}^\top B_n` in the tests).
:math:`P^2 + Q^2 = B^2 - b_x^2` is the radial field: it vanishes when the axis lies
along the field line, the **geomagnetic blind area** where the roll is not measurable.

Roll from the radial components ([Spin SR-CH∞KF] eq. 7-8)
---------------------------------------------------------
Inverting the pair above, :math:`(P^2+Q^2)\cos\gamma = P b_y - Q b_z` and
:math:`(P^2+Q^2)\sin\gamma = -Q b_y - P b_z`, so

.. math::

    \gamma = \operatorname{atan2}(-Q b_y - P b_z,\ P b_y - Q b_z),

eq. 7's ratio (numerator and denominator both divided by :math:`-B\cos I`) evaluated
with the four-quadrant rule.  The paper's printed quadrant offsets (eq. 8 with
:math:`\gamma_m = |\arctan(\cdot)|` plus 0°/90°/180°/270°) are not continuous as printed;
``atan2`` is the rule they describe.  :math:`P, Q` use the estimated pitch and yaw.

Euler rates (the paper's eq. 2, re-derived)
-------------------------------------------
For :math:`C_{nb}` above the body rate is
:math:`\omega_y = \dot\beta\cos\alpha\cos\gamma + \dot\alpha\sin\gamma`,
:math:`\omega_z = -\dot\beta\cos\alpha\sin\gamma + \dot\alpha\cos\gamma`,
:math:`\omega_x = \dot\gamma + \dot\beta\sin\alpha`; inverted,

.. math::

    \dot\alpha = \omega_y\sin\gamma + \omega_z\cos\gamma,\qquad
    \dot\beta = (\omega_y\cos\gamma - \omega_z\sin\gamma)/\cos\alpha,\qquad
    \dot\gamma = \omega_x - \tan\alpha\,(\omega_y\cos\gamma - \omega_z\sin\gamma).

The paper's eq. 2 prints the first two with :math:`\alpha` and :math:`\beta` exchanged
(the :math:`1/\cos` belongs to the yaw, as its own :math:`\dot\gamma` row implies).

Flight
------
A point mass in NUE with quadratic drag in an exponential atmosphere and a constant
crosswind :math:`w = [0, 0, w_E]`:

.. math::

    \dot v = -k\, e^{-h/H}\, |v - w|\,(v - w) - g\,e_U ,

launched at 897 m/s, pitch 45°, yaw 0° (Table 2).  The body axis follows the velocity:
:math:`\alpha = \operatorname{atan2}(v_U, \sqrt{v_N^2+v_E^2})` (flight-path angle),
:math:`\beta = \operatorname{atan2}(-v_E, v_N)`; the crosswind makes the small yaw drift.
The roll spins at :math:`\dot\gamma = 2\pi f_0 e^{-t/\tau}` (rev/s, decay time τ):
:math:`\gamma(t) = \gamma_0 + 2\pi f_0\tau(1 - e^{-t/\tau})`.  The drag constant
:math:`k` is either given or calibrated (:func:`calibrate_drag`) so that the flight time,
the range and the apex meet Table 2's 87.5 s, 27 126.4 m and 9 377 m in least squares; a
calibration that misses a target by more than :data:`CALIBRATION_TOLERANCE`, or ends at a
bound of its search, is a world error (:func:`calibration_miss`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

G = 9.80665
"""Standard gravity (m/s²)."""

__all__ = ["Field", "Flight", "FlightSpec", "Trajectory", "attitude_dcm", "blind_area",
           "body_field", "calibrate_drag", "calibration_miss", "fly", "radial_blind",
           "roll_from_field", "target_misses", "trajectory"]


@dataclass(frozen=True)
class Field:
    """The geomagnetic field of Table 1: intensity ``B`` (nT), inclination ``I`` and
    declination ``D`` (rad; I positive above the horizontal, D positive west of north)."""

    intensity_nt: float
    inclination_rad: float
    declination_rad: float

    @property
    def nav(self) -> Array:
        """:math:`B_n` in NUE (nT), eq. 4."""
        B, I, D = self.intensity_nt, self.inclination_rad, self.declination_rad
        return B * np.array([math.cos(D) * math.cos(I), math.sin(I), -math.sin(D) * math.cos(I)])


def _pq(field: Field, alpha: Array, beta: Array) -> tuple[Array, Array]:
    """:math:`P` and :math:`Q` of the module docstring (nT)."""
    B, I, D = field.intensity_nt, field.inclination_rad, field.declination_rad
    p = B * (math.sin(I) * np.cos(alpha) - math.cos(I) * np.sin(alpha) * np.cos(D - beta))
    return p, B * math.cos(I) * np.sin(D - beta)


def axial_field(field: Field, alpha: Array, beta: Array) -> Array:
    """:math:`b_x` ([Spin SR-CH∞KF] eq. 6, first row), nT."""
    B, I, D = field.intensity_nt, field.inclination_rad, field.declination_rad
    return (B * math.cos(I) * np.cos(alpha) * np.cos(D - beta)
            + B * math.sin(I) * np.sin(alpha))


def body_field(field: Field, alpha: Array, beta: Array, gamma: Array) -> Array:
    """``(..., 3)`` body components :math:`[b_x, b_y, b_z]` (eq. 6), nT."""
    p, q = _pq(field, alpha, beta)
    cg, sg = np.cos(gamma), np.sin(gamma)
    return np.stack([axial_field(field, alpha, beta), p * cg - q * sg, -p * sg - q * cg],
                    axis=-1)


def roll_from_field(field: Field, alpha: Array, beta: Array, by: Array, bz: Array) -> Array:
    """Roll from the radial components and the (estimated) pitch and yaw, eq. 7-8 with the
    four-quadrant rule: :math:`\\gamma = \\operatorname{atan2}(-Q b_y - P b_z, P b_y - Q b_z)`."""
    p, q = _pq(field, alpha, beta)
    return np.arctan2(-q * by - p * bz, p * by - q * bz)


def axis_field_angle(field: Field, alpha: Array, beta: Array) -> Array:
    """Angle (rad, in [0, π/2]) between the body axis and the field *line* (either sense)."""
    c = np.clip(np.abs(axial_field(field, alpha, beta)) / field.intensity_nt, 0.0, 1.0)
    return np.arccos(c)


def blind_area(field: Field, alpha: Array, beta: Array, threshold_rad: float) -> Array:
    """The geomagnetic blind area: the body axis within ``threshold_rad`` of the field line,
    i.e. the radial field :math:`\\sqrt{B^2 - b_x^2} < B\\sin(\\text{threshold})`."""
    return axis_field_angle(field, alpha, beta) < threshold_rad


def radial_blind(field: Field, mag: Array, threshold_rad: float) -> Array:
    r"""The blind-area detector a flight computer can run: the *measured* radial field
    :math:`\sqrt{\tilde b_y^2 + \tilde b_z^2}` below :math:`B\sin(\text{threshold})`
    (``mag`` is ``(E, 3)`` body-frame readings, nT)."""
    return np.hypot(mag[:, 1], mag[:, 2]) < field.intensity_nt * math.sin(threshold_rad)


def attitude_dcm(alpha: Array, beta: Array, gamma: Array) -> Array:
    """:math:`C_{nb} = R_y(\\beta) R_z(\\alpha) R_x(\\gamma)` as ``(..., 3, 3)``."""
    ca, sa = np.cos(alpha), np.sin(alpha)
    cb, sb = np.cos(beta), np.sin(beta)
    cg, sg = np.cos(gamma), np.sin(gamma)
    one, zero = np.ones_like(ca), np.zeros_like(ca)
    ry = np.stack([np.stack([cb, zero, sb], -1), np.stack([zero, one, zero], -1),
                   np.stack([-sb, zero, cb], -1)], -2)
    rz = np.stack([np.stack([ca, -sa, zero], -1), np.stack([sa, ca, zero], -1),
                   np.stack([zero, zero, one], -1)], -2)
    rx = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, cg, -sg], -1),
                   np.stack([zero, sg, cg], -1)], -2)
    return ry @ rz @ rx


# --------------------------------------------------------------------------- flight

@dataclass(frozen=True)
class FlightSpec:
    """Launch, atmosphere and drag (SI units, radians).

    ``drag_k_per_m``: :math:`k` of the module docstring, or ``None`` to calibrate it to
    the targets (``target_*``); ``scale_height_m`` :math:`H`; ``crosswind_mps`` the
    eastward wind :math:`w_E`.
    """

    speed_mps: float
    pitch_rad: float
    yaw_rad: float
    scale_height_m: float
    crosswind_mps: float
    drag_k_per_m: float | None
    target_flight_time_s: float
    target_range_m: float
    target_apex_m: float


@dataclass(frozen=True)
class Flight:
    """A flown trajectory: ``k`` used, flight time, range (horizontal distance at impact),
    apex height, and the dense solution ``state(t) -> (6, len(t))``
    ``[N, U, E, v_N, v_U, v_E]``."""

    k_per_m: float
    flight_time_s: float
    range_m: float
    apex_m: float
    state: object

    def sample(self, t: Array) -> Array:
        """``(len(t), 6)`` state at times ``t`` (within the flight)."""
        return np.asarray(self.state(np.asarray(t, dtype=float))).T  # type: ignore[operator]


def fly(spec: FlightSpec, k: float) -> Flight:
    """Integrate the flight with drag constant ``k`` until it returns to the ground."""
    w_e, H, k = float(spec.crosswind_mps), float(spec.scale_height_m), float(k)

    def rhs(_t: float, s: Array) -> Array:
        # scalar float arithmetic: a trial step of the integrator far off the solution
        # gives inf (rejected by its step control), never a numpy overflow warning; the
        # density is held at the ground's below it (only trial steps past impact go there)
        vn, vu, ve = float(s[3]), float(s[4]), float(s[5])
        c = -k * math.exp(-max(float(s[1]), 0.0) / H) * math.hypot(vn, vu, ve - w_e)
        return np.array([vn, vu, ve, c * vn, c * vu - G, c * (ve - w_e)])

    def ground(t: float, s: Array) -> float:
        return s[1] if t > 1.0 else 1.0

    ground.terminal = True  # type: ignore[attr-defined]
    ground.direction = -1  # type: ignore[attr-defined]
    v0 = spec.speed_mps * np.array([math.cos(spec.pitch_rad) * math.cos(spec.yaw_rad),
                                    math.sin(spec.pitch_rad),
                                    -math.cos(spec.pitch_rad) * math.sin(spec.yaw_rad)])
    from scipy.integrate import solve_ivp  # here: the world schema imports this module
    from scipy.optimize import brentq

    try:  # the filter loop's policy: a numeric warning is an error, never printed
        with np.errstate(divide="raise", over="raise", invalid="raise", under="ignore"):
            sol = solve_ivp(rhs, (0.0, 1000.0), np.concatenate([np.zeros(3), v0]),
                            method="DOP853", rtol=1e-11, atol=1e-9, events=ground,
                            dense_output=True)
    except (FloatingPointError, OverflowError) as exc:
        raise ValueError(f"the flight equations cannot be integrated with k = {k:.4g} /m "
                         f"({type(exc).__name__}: {exc})") from None
    if not sol.t_events[0].size:
        raise ValueError("the projectile does not return to the ground within 1000 s")
    T = float(sol.t_events[0][0])
    impact = sol.y_events[0][0]
    t_apex = brentq(lambda t: sol.sol(t)[4], 0.0, T, xtol=1e-12)
    return Flight(k, T, float(math.hypot(impact[0], impact[2])), float(sol.sol(t_apex)[1]),
                  sol.sol)


NO_FLIGHT_MISFIT = 1e100
"""The misfit of a drag with no flight: far above any real one, and finite, so that the
bounded search's parabolic steps (differences and products of misfits) stay finite."""


def _misfit(spec: FlightSpec, k: float) -> float:
    try:
        f = fly(spec, k)
    except ValueError:  # no flight with this k: never the fit
        return NO_FLIGHT_MISFIT
    rel = np.array([f.flight_time_s / spec.target_flight_time_s, f.range_m / spec.target_range_m,
                    f.apex_m / spec.target_apex_m]) - 1.0
    return float(rel @ rel)


DRAG_BOUNDS = (1e-7, 1e-3)
"""The calibration's search interval for :math:`k` (1/m)."""
CALIBRATION_TOLERANCE = 0.02
"""Largest relative miss of any target a calibrated drag may leave (Table 2's flight is
met to 0.6 % by the bundled world's)."""
TARGETS = (("flight_time_s", "target_flight_time_s", "flight time", "s"),
           ("range_m", "target_range_m", "range", "m"),
           ("apex_m", "target_apex_m", "apex", "m"))
"""``(Flight attribute, FlightSpec target, name, unit)`` of each calibration target."""


@functools.lru_cache(maxsize=8)
def calibrate_drag(spec: FlightSpec) -> float:
    """The :math:`k` (1/m) minimising the summed squared relative misses of flight time,
    range and apex (one parameter, three targets: a least-squares fit, not an exact one),
    searched in :data:`DRAG_BOUNDS`."""
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(lambda k: _misfit(spec, k), bounds=DRAG_BOUNDS, method="bounded",
                          options={"xatol": 1e-12})
    return float(res.x)


def target_misses(spec: FlightSpec, flight: Flight) -> dict[str, float]:
    """Relative miss (flown / target - 1) of each target, by the target's key."""
    return {key: getattr(flight, attr) / getattr(spec, key) - 1.0
            for attr, key, _, _ in TARGETS}


def calibration_miss(spec: FlightSpec, flight: Flight) -> tuple[str, str] | None:
    """``(key, reason)`` when a calibrated drag does not give the targets' flight: a target
    missed by more than :data:`CALIBRATION_TOLERANCE`, or the drag at a bound of its
    search (the fit wanted a drag outside it); ``None`` when it does, or the drag is given."""
    if spec.drag_k_per_m is not None:
        return None
    miss = target_misses(spec, flight)
    flown = ", ".join(f"{name} {getattr(flight, attr):.4g} {unit} ({key} = "
                      f"{getattr(spec, key):g}, {100 * miss[key]:+.1f} %)"
                      for attr, key, name, unit in TARGETS)
    lo, hi = DRAG_BOUNDS
    k = flight.k_per_m
    if k <= lo * (1 + 1e-3) or k >= hi * (1 - 1e-3):
        return ("flight.drag_k_per_m",
                f"left out (calibrated), but the best drag sits at its search bound "
                f"{lo if k <= lo * (1 + 1e-3) else hi:g} /m: {flown}; the launch (speed_mps, "
                "pitch_deg) and the targets do not describe one flight")
    worst = max(miss, key=lambda key: abs(miss[key]))
    if abs(miss[worst]) <= CALIBRATION_TOLERANCE:
        return None
    return (f"flight.{worst}",
            f"the calibrated drag k = {k:.4g} /m misses it by more than "
            f"{100 * CALIBRATION_TOLERANCE:g} %: {flown}; the launch (speed_mps, "
            "pitch_deg) and the targets do not describe one flight")


@functools.lru_cache(maxsize=8)
def trajectory(spec: FlightSpec) -> Flight:
    """The flight with the spec's ``k`` (calibrated when it gives none); cached per process."""
    k = spec.drag_k_per_m if spec.drag_k_per_m is not None else calibrate_drag(spec)
    return fly(spec, k)


@dataclass(frozen=True)
class Trajectory:
    """The truth sampled at the epochs ``times``: pitch, yaw, roll (rad) and the mean pitch
    and yaw rates over each interval (``(E - 1,)``, rad/s), the roll rate (rad/s)."""

    times: Array
    alpha: Array
    beta: Array
    gamma: Array
    alpha_rate: Array
    beta_rate: Array
    roll_rate: Array


def attitude_at(flight: Flight, times: Array, spin_rev_s: float, spin_decay_s: float,
                roll0_rad: float = 0.0) -> Trajectory:
    """Pitch and yaw following the velocity, roll spinning and decaying (module docstring);
    the rates are exact interval means (differences of the angles over ``dt``)."""
    s = flight.sample(times)
    vn, vu, ve = s[:, 3], s[:, 4], s[:, 5]
    alpha = np.arctan2(vu, np.hypot(vn, ve))
    beta = np.arctan2(-ve, vn)
    w0 = 2.0 * math.pi * spin_rev_s
    if math.isinf(spin_decay_s):
        gamma = roll0_rad + w0 * times
        rate = np.full_like(times, w0)
    else:
        gamma = roll0_rad + w0 * spin_decay_s * (1.0 - np.exp(-times / spin_decay_s))
        rate = w0 * np.exp(-times / spin_decay_s)
    dt = np.diff(times)
    return Trajectory(times, alpha, beta, np.mod(gamma, 2.0 * math.pi),
                      np.diff(alpha) / dt, np.diff(beta) / dt, rate)
