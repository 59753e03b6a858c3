"""nav.arrays: the simulators' read-only arrays."""

from __future__ import annotations

import numpy as np
import pytest

from nav.arrays import read_only


def test_read_only_is_contiguous_unwritable_and_keeps_values() -> None:
    a = np.arange(12.0).reshape(3, 4)[:, ::2]
    out = read_only(a)
    assert out.flags.c_contiguous and not out.flags.writeable
    assert np.array_equal(out, a) and out.dtype == a.dtype
    with pytest.raises(ValueError):
        out[0, 0] = 1.0


def test_read_only_casts_to_the_dtype() -> None:
    assert read_only([1, 2], np.float64).dtype == np.float64
    assert read_only(np.array([1.0, 2.0]), np.int64).dtype == np.int64
