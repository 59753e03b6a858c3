r"""The filters' model of the spinning projectile, the filter runs, and the GTSAM smoother
([Spin SR-CH∞KF] eq. 3, 6, 9).

State :math:`X = [\alpha, \beta]` (pitch, yaw; rad) on ``Angle(2)``.

* **Time update** (eq. 9 with eq. 3's increments, :mod:`slam.kinds.spinning.gyro`):
  :math:`X_k = X_{k-1} + \Delta t\, u_{k-1} + W_{k-1}` with
  :math:`u_{k-1} = \mathrm{resolve}(\omega_{k-1}, \hat\alpha_{k-1}, \hat\gamma_{k-1})`: the
  gyro's transverse body rates turned into pitch and yaw rates with the filter's pitch and
  the **magnetometer roll** :math:`\hat\gamma_{k-1}` (eq. 7-8 on the radial readings at
  :math:`t_{k-1}` with the filter's posterior pitch and yaw).  The roll enters as the paper
  has it: an *input*, taken as exact (eq. 9's :math:`B U`, the same for every sigma point,
  so the state equation stays linear: Jacobian :math:`I`); it is not a state and its error
  is not in :math:`Q`.  Its error, large in the blind area, is the model error the H∞
  bound is there for.  :math:`W \sim N(0, Q_{k-1})`,
  :math:`Q = \sigma_g^2 \Delta t\,\mathrm{diag}(1, 1/\cos^2\hat\alpha_{k-1})`: the gyro's
  white rate noise (density :math:`\sigma_g`, the same on both body channels) through
  eq. 3 (the yaw row is divided by :math:`\cos\alpha`).
* **Measurement** (eq. 6, first row; eq. 9's :math:`H`):
  :math:`z_k = b_x(X_k) + V_k = B\cos I\cos\alpha\cos(D-\beta) + B\sin I\sin\alpha + V_k`,
  :math:`V \sim N(0, \sigma_m^2)`, with the analytic Jacobian

  .. math::

      \frac{\partial b_x}{\partial\alpha} = B(\sin I\cos\alpha - \cos I\sin\alpha\cos(D-\beta)),
      \qquad \frac{\partial b_x}{\partial\beta} = B\cos I\cos\alpha\sin(D-\beta).

  The yaw enters only through :math:`\cos(D-\beta)`: it is unobservable to first order
  at :math:`\beta = D` and :math:`\beta` and :math:`2D-\beta` give the same reading.  The
  pitch derivative vanishes where the axis lies along the field's vertical plane at
  :math:`\tan\alpha = \tan I/\cos(D-\beta)`, i.e. in the blind area.

Every filter is :func:`estimators.make_filter`'s, run by :func:`estimators.loop.run_epochs`
(update at t = 0, then predict + update per epoch), with the world's settings
(``Models.settings``: ``[filters.unscented]`` for ``ukf``/``uthinf``, ``[filters.hinf]``
for the H∞ filters).  ``srchinf`` (SR-CH∞KF, eq. 12-33) and ``uthinf`` take the bound γ
(the paper's κ, rad) and ``on_failure``; each update whose
Riccati existence condition (eq. 25/33) fails is counted (``Innovation.hinf_fallback``;
with ``on_failure="kalman"`` that update is the Kalman one, with ``"raise"`` the run ends
as diverged).

The smoother (:func:`smooth`) is GTSAM on the same log and the same (assumed) noise:
``Vector2`` keys per epoch, between-factors (``gtsam.CustomFactor``, analytic Jacobians)

.. math::

    e_k = \begin{bmatrix} \alpha_k - \alpha_{k-1} \\ \cos\alpha_{k-1}(\beta_k - \beta_{k-1})
          \end{bmatrix} - \Delta t\,\begin{bmatrix} \omega_y\sin\gamma + \omega_z\cos\gamma \\
          \omega_y\cos\gamma - \omega_z\sin\gamma\end{bmatrix},\qquad
    \gamma = \gamma(X_{k-1};\ \tilde b_{y}, \tilde b_{z})

(eq. 3 with the roll of eq. 7-8 at the smoother's own :math:`X_{k-1}`: the same roll
input as the filters', here a function of the state; the yaw row times
:math:`\cos\alpha_{k-1}` so that the noise is isotropic, σ :math:`\sigma_g\sqrt{\Delta t}`),
unary ``CustomFactor`` s :math:`e = b_x(X_k) - z_k` (σ :math:`\sigma_m`, the analytic
Jacobian above), a prior equal to the filters' initial belief; Levenberg-Marquardt from
an EKF pass (:func:`initial_guess`, :func:`levenberg_marquardt`); GTSAM's marginal
covariances.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from estimators import Angle, Measurement, Noise, NoiseError, Transition, make_filter
from estimators.loop import run_epochs
from slam.kinds.spinning.gyro import magnetometer_roll, resolve, roll_gradient
from slam.kinds.spinning.simulate import SpinLog
from slam.kinds.spinning.truth import Field, axial_field
from slam.results import REFERENCE

Array = NDArray[np.float64]

STATE = Angle(2)


def axial_jacobian(fld: Field, x: Array) -> Array:
    """``(1, 2)`` :math:`[\\partial b_x/\\partial\\alpha, \\partial b_x/\\partial\\beta]` at
    ``x = [α, β]`` (module docstring)."""
    B, I, D = fld.intensity_nt, fld.inclination_rad, fld.declination_rad
    a, b = float(x[0]), float(x[1])
    return np.array([[B * (math.sin(I) * math.cos(a) - math.cos(I) * math.sin(a) * math.cos(D - b)),
                      B * math.cos(I) * math.cos(a) * math.sin(D - b)]])


@dataclass(frozen=True)
class RateNoise:
    """The time update's diagonal noise :math:`\\mathrm{diag}(s_\\alpha^2, s_\\beta^2)`, formed
    without :class:`~estimators.Noise`'s general checks (a new one every step; the filters
    read ``cov``, ``sqrt`` and ``dim``): both σ must be finite and positive, else
    :class:`~estimators.NoiseError` (a counted divergence, e.g. a pitch estimate at ±90°)."""

    cov: Array
    sqrt: Array
    dim: int = 2

    @classmethod
    def of(cls, s_alpha: float, s_beta: float) -> RateNoise:
        if not (0.0 < s_alpha < math.inf and 0.0 < s_beta < math.inf):
            raise NoiseError(f"gyro rate noise σ ({s_alpha:.3g}, {s_beta:.3g}) rad is not "
                             "finite and positive (pitch estimate at ±90°?)")
        sd = np.array([[s_alpha, 0.0], [0.0, s_beta]])
        return cls(sd * sd, sd)


@dataclass(frozen=True)
class GyroModel:
    """Eq. 3 as the filters use it (module docstring): sample interval ``dt``, the gyro's
    assumed rate noise density ``rate_noise`` (rad/s/√Hz) and the field for the roll."""

    dt: float
    rate_noise: float
    field: Field

    def transition(self, alpha: float) -> Transition:
        """``f(X, u) = X + Δt u`` with :math:`Q = \\sigma_g^2 \\Delta t\\,
        \\mathrm{diag}(1, 1/\\cos^2\\hat\\alpha)` at the estimated pitch ``alpha``."""
        s = self.rate_noise * math.sqrt(self.dt)
        dt = self.dt
        with np.errstate(divide="ignore"):
            noise = RateNoise.of(s, s / abs(math.cos(alpha)))
        return Transition(lambda X, u: X + dt * u, noise,  # type: ignore[arg-type]
                          jacobian=lambda x, u: _EYE)

    def step(self, x: Array, omega: Array, mag: Array) -> tuple[Transition, Array]:
        """The transition and its input from the estimate ``x``, the gyro sample ``omega``
        (2,) and the magnetometer reading ``mag`` (3,) at the same epoch: the rates of eq. 3
        resolved with the magnetometer roll."""
        roll = magnetometer_roll(self.field, x, mag)
        return self.transition(float(x[0])), resolve(np.asarray(omega), x[0], roll)


_EYE = np.eye(2)


def measurement(fld: Field, sigma_nt: float) -> Measurement:
    """Eq. 6's axial component with noise ``sigma_nt`` and its analytic Jacobian."""
    return Measurement(lambda X: axial_field(fld, X[:, 0], X[:, 1])[:, None],
                       Noise.from_sigmas([sigma_nt]), jacobian=lambda x: axial_jacobian(fld, x))


@dataclass(frozen=True)
class Models:
    """What a filter run needs besides the log: models, prior, and each filter's settings
    (``settings[name]``: :func:`estimators.make_filter`'s keywords; none for a filter not
    listed)."""

    gyro: GyroModel
    measurement: Measurement
    x0: Array
    P0: Array
    settings: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def with_settings(self, name: str, **changes: Any) -> Models:
        """These models with filter ``name``'s settings changed (e.g. ``gamma``)."""
        mine = {**self.settings.get(name, {}), **changes}
        return replace(self, settings={**self.settings, name: mine})


def world_models(world: Any, log: SpinLog, rng: np.random.Generator) -> Models:
    r"""A world's filter models (its *assumed* noises, its filters' settings) and a prior
    drawn around the truth: :math:`\hat x_0 = x_0 + N(0, P_0)`,
    :math:`P_0 = \mathrm{diag}(\sigma_0^2)` (``[filters] initial_sigma_deg``)."""
    P0 = np.diag(np.square(world.filters.initial_sigma_rad))
    x0 = log.truth[0] + np.sqrt(np.diag(P0)) * rng.standard_normal(2)
    fs = world.filters
    names = dict.fromkeys([*fs.names, *world.sweep.filters])
    return Models(GyroModel(log.dt, world.gyro.rate_noise_rad_s_sqrt_hz, world.field),
                  measurement(world.field, world.magnetometer.noise_nt), x0, P0,
                  {n: fs.settings_of(n) for n in names})


@dataclass(frozen=True, kw_only=True)
class RunFacts:
    """How a run of one estimator went: wall ``time_s`` of its ``cycles`` predict + update
    cycles (smoother: graph + solve; ``extra_time_s`` the marginals), the ``updates`` and
    among them the ``fallbacks`` (H∞ existence condition failed), and whether (and why)
    it ``diverged``."""

    time_s: float
    cycles: int
    fallbacks: int = 0
    updates: int = 0
    diverged: bool = False
    failure: str | None = None
    extra_time_s: float = 0.0


def facts(run: RunFacts) -> dict[str, Any]:
    """The :class:`RunFacts` fields of ``run`` (to pass them on)."""
    return {f.name: getattr(run, f.name) for f in fields(RunFacts)}


@dataclass(frozen=True, kw_only=True)
class Series(RunFacts):
    """One estimator's output at the epochs: ``means`` (E, 2), ``covs`` (E, 2, 2) (NaN
    after a failure), ``nis`` (E,) (NaN for the smoother), the epochs of the H∞
    existence failures."""

    name: str
    means: Array
    covs: Array
    nis: Array
    fallback_epochs: Array = field(default_factory=lambda: np.zeros(0, dtype=int))


def run_filter(log: SpinLog, name: str, m: Models, label: str | None = None) -> Series:
    """Run filter ``name`` (with ``m.settings[name]``) over the log (module docstring);
    ``label`` names the series."""
    E = log.n_epochs
    flt = make_filter(name, **m.settings.get(name, {}))
    means = np.full((E, 2), np.nan)
    covs = np.full((E, 2, 2), np.nan)
    nis = np.full(E, np.nan)
    falls: list[int] = []

    def record(k: int, b) -> None:
        means[k], covs[k] = b.mean, b.cov

    def correct(k: int, b):
        b, inn = flt.update(b, m.measurement, log.mag[k, :1])
        if inn.hinf_fallback:
            falls.append(k)
        return b, [inn]

    def transition(k: int, b):
        return m.gyro.step(b.mean, log.gyro[k - 1], log.mag[k - 1])

    out = run_epochs(flt, flt.init(m.x0, STATE, cov=m.P0), E, correct_first=True,
                     record=record, transition=transition, correct=correct)
    nis[out.nis_epoch] = out.nis
    return Series(name=label or name, means=means, covs=covs, nis=nis, time_s=out.time_s,
                  cycles=E - 1, fallbacks=len(falls), updates=len(out.nis),
                  diverged=out.diverged, failure=out.failure,
                  fallback_epochs=np.array(falls, dtype=int))


def dead_reckoning(log: SpinLog, x0: Array, fld: Field) -> Array:
    """``(E, 2)`` eq. 3 integrated from ``x0`` without updates, each step's gyro sample
    resolved with the magnetometer roll at the dead-reckoned pitch and yaw."""
    out = np.empty((log.n_epochs, 2))
    out[0] = x0
    for k in range(1, log.n_epochs):
        x = out[k - 1]
        roll = magnetometer_roll(fld, x, log.mag[k - 1])
        out[k] = x + log.dt * resolve(np.asarray(log.gyro[k - 1]), x[0], roll)
    return out


def initial_guess(log: SpinLog, m: Models) -> Array:
    """``(E, 2)`` where the smoother starts: an EKF pass on the same log and models, or dead
    reckoning (:func:`dead_reckoning`) if that pass fails.  Dead reckoning alone resolves
    the gyro with the roll at its own drifting estimate and loses it in the blind area,
    where Levenberg-Marquardt then needs tens of iterations to come back."""
    ekf = run_filter(log, "ekf", m)
    if ekf.diverged or not np.all(np.isfinite(ekf.means)):
        return dead_reckoning(log, m.x0, m.gyro.field)
    return ekf.means


def between_error(fld: Field, dt: float, omega: Array, mag: Array, a: Array, b: Array
                  ) -> tuple[Array, Array, Array]:
    """The smoother's eq. 3 factor (module docstring) between ``a`` = :math:`X_{k-1}` and
    ``b`` = :math:`X_k`: the error (2,) and its Jacobians (2, 2) in ``a`` and ``b``."""
    wy, wz = float(omega[0]), float(omega[1])
    roll = magnetometer_roll(fld, a, mag)
    cg, sg = math.cos(roll), math.sin(roll)
    r_a, r_p = wy * sg + wz * cg, wy * cg - wz * sg  # pitch rate, transverse yaw rate
    ca, sa = math.cos(a[0]), math.sin(a[0])
    db = float(b[1] - a[1])
    err = np.array([b[0] - a[0] - dt * r_a, ca * db - dt * r_p])
    g = roll_gradient(fld, a, mag)  # d roll / d a
    Ja = np.array([[-1.0 - dt * r_p * g[0], -dt * r_p * g[1]],
                   [-sa * db + dt * r_a * g[0], -ca + dt * r_a * g[1]]])
    Jb = np.array([[1.0, 0.0], [0.0, ca]])
    return err, Ja, Jb


def _between(fld: Field, dt: float, omega: Array, mag: Array):
    def err(this: Any, values: Any, H: list[Array] | None) -> Array:
        k0, k1 = this.keys()
        e, Ja, Jb = between_error(fld, dt, omega, mag, values.atVector(k0),
                                  values.atVector(k1))
        if H is not None:
            H[0], H[1] = Ja, Jb
        return e
    return err


def _axial(fld: Field, z: float):
    def err(this: Any, values: Any, H: list[Array] | None) -> Array:
        x = values.atVector(this.keys()[0])
        if H is not None:
            H[0] = axial_jacobian(fld, x)
        return np.array([float(axial_field(fld, x[0], x[1])) - z])
    return err


def levenberg_marquardt(graph: Any, values: Any, keys: list[int], max_iterations: int = 50,
                        rel_tol: float = 1e-9) -> tuple[Any, int]:
    r"""Levenberg-Marquardt on a GTSAM graph: each iteration linearises the graph with
    GTSAM (``graph.linearize``), adds the damping :math:`\lambda I` as a unit
    ``JacobianFactor`` :math:`\sqrt\lambda\,\delta_j = 0` per key, solves by GTSAM's
    sparse elimination, and accepts the step if :math:`\tfrac12\chi^2` does not grow
    (then :math:`\lambda /= 10`, else :math:`\lambda *= 10` and retry); it stops when the
    relative decrease falls below ``rel_tol``.  Returns the values and the iterations.

    The iteration runs here rather than in ``gtsam.LevenbergMarquardtOptimizer`` because
    that optimizer hands every ``CustomFactor`` call a copy of the whole ``Values``: the
    cost grows with the square of the number of keys (about 3-8 s per run at 871 keys,
    against ~0.3 s here for the same iterates).
    """
    import gtsam

    unit = gtsam.noiseModel.Unit.Create(2)
    zero = np.zeros(2)
    ordering = gtsam.Ordering()  # the chain's own order: no fill-in
    for k in keys:
        ordering.push_back(k)
    lam, error = 1e-5, graph.error(values)
    for it in range(1, max_iterations + 1):
        lin = graph.linearize(values)
        while True:
            damped = lin.clone()
            root = math.sqrt(lam) * np.eye(2)
            for k in keys:
                damped.add(gtsam.JacobianFactor(k, root, zero, unit))
            trial = values.retract(damped.optimize(ordering))
            new_error = graph.error(trial)
            if new_error <= error or lam > 1e10:
                break
            lam *= 10.0
        decrease = error - new_error
        if new_error <= error:
            values, lam = trial, max(lam / 10.0, 1e-12)
        if not decrease > rel_tol * max(error, 1e-300):
            return values, it
        error = new_error
    return values, max_iterations


def smooth(log: SpinLog, m: Models, fld: Field, rate_noise: float, mag_sigma: float,
           marginals: bool = True) -> Series:
    """GTSAM batch smoother on the same log (module docstring)."""
    import gtsam

    t0 = time.perf_counter()
    E, dt = log.n_epochs, log.dt
    keys = [gtsam.symbol("x", k) for k in range(E)]
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorVector(keys[0], m.x0, gtsam.noiseModel.Gaussian.Covariance(m.P0)))
    between = gtsam.noiseModel.Isotropic.Sigma(2, rate_noise * math.sqrt(dt))
    unary = gtsam.noiseModel.Isotropic.Sigma(1, mag_sigma)
    for k in range(E):
        graph.add(gtsam.CustomFactor(unary, [keys[k]], _axial(fld, float(log.mag[k, 0]))))
        if k:
            graph.add(gtsam.CustomFactor(between, [keys[k - 1], keys[k]],
                                         _between(fld, dt, np.array(log.gyro[k - 1]),
                                                  np.array(log.mag[k - 1]))))
    values = gtsam.Values()
    for k, x in zip(keys, initial_guess(log, m)):
        values.insert(k, x)
    result, _ = levenberg_marquardt(graph, values, keys)
    means = np.array([result.atVector(k) for k in keys])
    solve_s = time.perf_counter() - t0
    covs = np.full((E, 2, 2), np.nan)
    t1 = time.perf_counter()
    if marginals:
        marg = gtsam.Marginals(graph, result)
        covs = np.array([marg.marginalCovariance(k) for k in keys])
    return Series(name=REFERENCE, means=means, covs=covs, nis=np.full(E, np.nan),
                  time_s=solve_s, cycles=E - 1, extra_time_s=time.perf_counter() - t1)
