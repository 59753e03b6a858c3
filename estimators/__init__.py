"""Model-agnostic Gaussian filters (numpy/scipy only; no navigation knowledge).

Importing the package limits BLAS to one thread unless ``NAVFILTERS_BLAS_THREADS`` says
otherwise (:mod:`estimators.threads`).
"""


from .consistency import anees_band, anees_stats, chi2_band, nees, nis, nis_stats
from .filters import (
    FILTER_NAMES,
    ROBUST_FILTER_NAMES,
    SETTINGS,
    Filter,
    describe_settings,
    make_filter,
    settings_for,
)
from .finite import NonFiniteError
from .hinf import HInfinityFilter, RiccatiConditionError
from .homm import HighOrderMoment
from .linalg import NotPositiveDefiniteError, chol, chol_update, svd_factor, tria
from .models import (
    Gaussian,
    Innovation,
    Measurement,
    Noise,
    NoiseError,
    SqrtGaussian,
    Transition,
)
from .partitioned import PARTITIONED_FILTERS, BlockLayout, NoPartitionedModeError
from .rules import CentralDifference, Cubature, Unscented
from .spaces import Angle, Euclidean, Product, Space, Wrapped, wrap_angle

__all__ = [
    "FILTER_NAMES", "ROBUST_FILTER_NAMES", "Filter", "make_filter", "HInfinityFilter",
    "RiccatiConditionError", "HighOrderMoment", "NotPositiveDefiniteError", "chol", "chol_update",
    "svd_factor", "tria", "Gaussian", "Innovation", "Measurement", "Noise", "SqrtGaussian",
    "Transition", "CentralDifference", "Cubature", "Unscented", "Angle", "Euclidean",
    "Product", "Space", "Wrapped", "wrap_angle", "PARTITIONED_FILTERS", "BlockLayout",
    "NoPartitionedModeError", "NonFiniteError", "NoiseError", "SETTINGS", "describe_settings",
    "settings_for", "nees", "nis", "chi2_band", "anees_band", "anees_stats", "nis_stats",
]

from .threads import pin_by_default  # noqa: E402  (after numpy and scipy are loaded)

pin_by_default()
