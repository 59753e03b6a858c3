r"""The true sensor noise: a factor times what the filters assume, Gaussian or not.

The filters assume white Gaussian noise of standard deviation :math:`\sigma` (the world's
``[gyro]`` and ``[magnetometer]`` values).  The simulation draws
:math:`v = f\,\sigma\,\epsilon` with the world's factor :math:`f` (``[truth_noise]``) and
a unit-scale :math:`\epsilon` of one of three shapes:

* ``"gaussian"``: :math:`\epsilon \sim N(0, 1)`;
* ``"student-t"``: :math:`\epsilon = t_\nu \sqrt{(\nu-2)/\nu}`, Student's t with
  :math:`\nu` degrees of freedom scaled to unit variance (same variance as the Gaussian,
  heavier tails; kurtosis :math:`3 + 6/(\nu-4)` for :math:`\nu > 4`, infinite below);
* ``"contaminated"``: :math:`\epsilon \sim N(0, 1)` with probability :math:`1-\varepsilon`
  and :math:`N(0, c^2)` with probability :math:`\varepsilon` (outliers; variance
  :math:`1 - \varepsilon + \varepsilon c^2`, so the factor sets the *nominal* part).

Draws happen in a fixed order and number whatever the shape (a normal and a uniform
array for every shape), so a campaign's random stream does not depend on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from slam.scoring import chi2_ppf

Array = NDArray[np.float64]

DISTRIBUTIONS = ("gaussian", "student-t", "contaminated")


@dataclass(frozen=True)
class NoiseShape:
    """How the true noise differs from the assumed one (module docstring)."""

    magnetometer_factor: float = 1.0
    gyro_factor: float = 1.0
    distribution: str = "gaussian"
    student_t_dof: float = 3.0
    contamination_fraction: float = 0.05
    contamination_scale: float = 10.0

    def __post_init__(self) -> None:
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution must be one of {DISTRIBUTIONS}")
        if self.distribution == "student-t" and not self.student_t_dof > 2.0:
            raise ValueError("student_t_dof must be > 2 (finite variance)")

    @property
    def std_ratio(self) -> float:
        """Standard deviation of :math:`\\epsilon` (1 except for contamination)."""
        if self.distribution == "contaminated":
            eps, c = self.contamination_fraction, self.contamination_scale
            return math.sqrt(1.0 - eps + eps * c * c)
        return 1.0


def unit_noise(rng: np.random.Generator, shape: tuple[int, ...], ns: NoiseShape) -> Array:
    """:math:`\\epsilon` of ``shape`` (module docstring)."""
    normal = rng.standard_normal(shape)
    uniform = rng.random(shape)
    if ns.distribution == "gaussian":
        return normal
    if ns.distribution == "contaminated":
        scale = np.where(uniform < ns.contamination_fraction, ns.contamination_scale, 1.0)
        return normal * scale
    nu = ns.student_t_dof
    # t_nu = Z / sqrt(W / nu), W ~ chi2_nu drawn from the uniform by its inverse CDF
    w = chi2_ppf(np.clip(uniform, 1e-300, 1.0 - 1e-16), nu)
    return normal / np.sqrt(w / nu) * math.sqrt((nu - 2.0) / nu)
