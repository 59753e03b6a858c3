"""Array helpers shared by the simulators."""

from __future__ import annotations

import numpy as np
from numpy.typing import DTypeLike, NDArray


def read_only(a: object, dtype: DTypeLike | None = None) -> NDArray:
    """``a`` as a C-contiguous array (of ``dtype``, if given) that cannot be written to:
    a simulated log's arrays are shared by every filter run on it."""
    out = np.ascontiguousarray(a, dtype=dtype)
    out.setflags(write=False)
    return out
