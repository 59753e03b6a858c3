"""The filters by name, as the command line, the code and ``summary.json`` name them.

===========  =========================================================  ==========================
name         filter                                                     settings
===========  =========================================================  ==========================
``ekf``      extended Kalman filter (Joseph form)                       none
``ckf``      cubature Kalman filter, dense covariance                   none
``ukf``      unscented Kalman filter, dense covariance                  ``alpha beta kappa``
``cdkf``     central-difference Kalman filter, dense covariance         ``h``
``srckf``    square-root cubature Kalman filter (QR / ``tria``)         none
``srukf``    square-root unscented Kalman filter (QR + downdate)        ``alpha beta kappa``
``srcdkf``   square-root central-difference Kalman filter               ``h``
``svdckf``   cubature Kalman filter with an SVD-factored covariance     none
``hommukf``  high-order moment-matching UKF ([Ding 2017]), dense        moments skewness kurtosis
``iekf``     iterated EKF (Gauss-Newton update, step control)           ``iterations tolerance``
``isrckf``   SRCKF with the iterated posterior-linearisation update     ``iterations tolerance``
``isrukf``   SRUKF with the iterated posterior-linearisation update     as ``srukf`` and ``isrckf``
===========  =========================================================  ==========================

Robust filters (:data:`ROBUST_FILTER_NAMES`; they do *not* reduce to the Kalman filter
on a linear model for finite ``gamma``, so they are kept out of :data:`FILTER_NAMES`):

* ``srchinf``: square-root cubature H∞ filter ([Spin SR-CH∞KF]); settings ``gamma``,
  ``on_failure``;
* ``uthinf``: unscented H∞ filter ([Wu-Wang 2014]), dense; settings ``alpha``, ``beta``,
  ``kappa``, ``gamma``, ``on_failure``.

Settings (:data:`SETTINGS`; :data:`DEFAULTS` when not given):

* ``alpha``, ``beta``, ``kappa``: the scaled unscented rule (:class:`~estimators.rules.Unscented`;
  ``kappa`` a number or ``"3-n"``).  **The defaults α = 1, β = 2, κ = 0 give the cubature
  rule's points and mean weights in any dimension** (a centre point of mean weight 0 is
  added, with covariance weight 2): with them a UKF is a CKF with one changed weight.
  Worlds state their setting; reports print it (:func:`describe_settings`).
* ``h``: the central-difference step (√3, optimal for a Gaussian prior).
* ``gamma``: the H∞ bound (5, [Wu-Wang 2014]'s value; ``inf`` gives the Kalman twin; it must
  be large enough that 1/γ² is a finite number, γ ≥ :data:`MIN_GAMMA`); ``on_failure``:
  ``"raise"`` or ``"kalman"`` when the Riccati existence condition fails
  (:mod:`estimators.hinf`).
* ``moments``: where the HoMM rule takes the moments it matches - ``"predicted"`` (the
  default, [Ding 2017]'s mechanism: φ₁, φ₂ of the predicted points at every step, carried
  by the predicted belief; :mod:`estimators.homm`) or ``"fixed"`` (``skewness`` and
  ``kurtosis`` at every draw).  ``skewness``, ``kurtosis``: the standardised moments of
  the first draw, the noise axes and a refused estimate (``"predicted"``), or of every
  draw (``"fixed"``); 0 and 3 are a Gaussian's, where the fixed rule's points are Julier's
  κ = 3 − n set.
* ``iterations``, ``tolerance``: the iterated updates' most iterations and the whitened
  step below which they stop (:mod:`estimators.iterated`; 1 iteration is the one-pass
  update).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .ekf import ExtendedKalmanFilter
from .hinf import MIN_GAMMA, HInfinityFilter
from .homm import HighOrderMoment
from .iterated import IteratedEKF, IteratedSigmaPointFilter
from .rules import CentralDifference, Cubature, Unscented
from .sigma import SigmaPointFilter

Filter = ExtendedKalmanFilter | SigmaPointFilter | HInfinityFilter

FILTER_NAMES: tuple[str, ...] = ("ekf", "ckf", "ukf", "cdkf", "srckf", "srukf", "srcdkf",
                                 "svdckf", "hommukf", "iekf", "isrckf", "isrukf")

ROBUST_FILTER_NAMES: tuple[str, ...] = ("srchinf", "uthinf")

_UT = ("alpha", "beta", "kappa")
_HINF = ("gamma", "on_failure")
_IT = ("iterations", "tolerance")
SETTINGS: dict[str, tuple[str, ...]] = {
    "ekf": (), "ckf": (), "ukf": _UT, "cdkf": ("h",), "srckf": (), "srukf": _UT,
    "srcdkf": ("h",), "svdckf": (), "hommukf": ("moments", "skewness", "kurtosis"),
    "srchinf": _HINF, "uthinf": _UT + _HINF,
    "iekf": _IT, "isrckf": _IT, "isrukf": _UT + _IT,
}
"""The settings each filter takes (keyword arguments of :func:`make_filter`)."""

DEFAULTS: dict[str, Any] = {"alpha": 1.0, "beta": 2.0, "kappa": 0.0, "h": math.sqrt(3.0),
                            "gamma": 5.0, "on_failure": "raise", "moments": "predicted",
                            "skewness": 0.0, "kurtosis": 3.0, "iterations": 5, "tolerance": 1e-9}
"""A setting's value when :func:`make_filter` is not given it (module docstring)."""

__all__ = ["DEFAULTS", "FILTER_NAMES", "MIN_GAMMA", "ROBUST_FILTER_NAMES", "SETTINGS", "Filter",
           "describe_settings", "make_filter", "settings_for"]


def _build(name: str, s: dict[str, Any]) -> Filter:
    if name == "ekf":
        return ExtendedKalmanFilter()
    if name == "iekf":
        return IteratedEKF(iterations=s["iterations"], tolerance=s["tolerance"])
    if name in ("isrckf", "isrukf"):
        rule = Cubature() if name == "isrckf" else Unscented(s["alpha"], s["beta"], s["kappa"])
        return IteratedSigmaPointFilter(name, rule, "sqrt", iterations=s["iterations"],
                                        tolerance=s["tolerance"])
    if name in ("ckf", "srckf", "svdckf"):
        return SigmaPointFilter(name, Cubature(), {"ckf": "dense", "srckf": "sqrt",
                                                   "svdckf": "svd"}[name])
    if name in ("ukf", "srukf"):
        rule = Unscented(s["alpha"], s["beta"], s["kappa"])
        return SigmaPointFilter(name, rule, "dense" if name == "ukf" else "sqrt")
    if name in ("cdkf", "srcdkf"):
        return SigmaPointFilter(name, CentralDifference(s["h"]),
                                "dense" if name == "cdkf" else "sqrt")
    if name == "hommukf":
        return SigmaPointFilter(name, HighOrderMoment(s["skewness"], s["kurtosis"],
                                                      moments=s["moments"]), "dense")
    if name == "srchinf":
        return HInfinityFilter(name, Cubature(), "sqrt", s["gamma"], s["on_failure"])
    return HInfinityFilter(name, Unscented(s["alpha"], s["beta"], s["kappa"]), "dense",
                           s["gamma"], s["on_failure"])


def make_filter(name: str, **settings: Any) -> Filter:
    """Build the filter called ``name`` with its ``settings`` (module docstring).

    Only the settings the filter takes (:data:`SETTINGS`) are accepted; a setting not
    given takes its :data:`DEFAULTS` value.  Raises ``ValueError`` for an unknown name, a
    setting the filter does not take or a value out of its range (e.g. γ below
    :data:`MIN_GAMMA`).
    """
    if name not in SETTINGS:
        names = ", ".join(FILTER_NAMES + ROBUST_FILTER_NAMES)
        raise ValueError(f"unknown filter {name!r}; choose from {names}")
    allowed = SETTINGS[name]
    extra = sorted(set(settings) - set(allowed))
    if extra:
        takes = ", ".join(allowed) if allowed else "none"
        raise ValueError(f"filter {name!r} takes no setting {extra[0]!r} (its settings: {takes})")
    return _build(name, {**{k: DEFAULTS[k] for k in allowed}, **settings})


def settings_for(name: str, available: Mapping[str, Any]) -> dict[str, Any]:
    """The subset of ``available`` that filter ``name`` takes: a world's settings table
    (one value per setting name) turned into :func:`make_filter`'s keywords."""
    return {k: available[k] for k in SETTINGS[name] if k in available}


def describe_settings(filt: Filter) -> str:
    """A filter's tuning constants in one line (``"α = 1, β = 0, κ = 3 − n"``; ``""`` for a
    filter without any), with a warning when the unscented setting is the cubature one."""
    parts: list[str] = []
    rule = getattr(filt, "rule", None)
    if isinstance(rule, Unscented):
        k = "3 − n" if isinstance(rule.kappa, str) else f"{rule.kappa:g}"
        parts.append(f"α = {rule.alpha:g}, β = {rule.beta:g}, κ = {k}")
        if rule.cubature_equivalent:
            parts.append("(the cubature points: a CKF with one changed weight)")
    elif isinstance(rule, CentralDifference):
        parts.append(f"h = {rule.h:.4g}")
    elif isinstance(rule, HighOrderMoment):
        if rule.moments == "predicted":
            parts.append(f"moments of the predicted points ([Ding 2017] φ₁, φ₂); first draw "
                         f"and fallback skewness {rule.skewness:g}, kurtosis {rule.kurtosis:g}")
        else:
            parts.append(f"fixed skewness {rule.skewness}, kurtosis {rule.kurtosis}")
    its = getattr(filt, "iterations", None)
    if its is not None:
        parts.append(f"at most {its} iterations, tolerance {filt.tolerance:g}")
    if isinstance(filt, HInfinityFilter):
        parts.append(f"γ = {filt.gamma:g}, on failure: {filt.on_failure}")
    return ", ".join(p for p in parts if not p.startswith("(")) + "".join(
        f" {p}" for p in parts if p.startswith("("))
