"""A user's test: my filter on two tiny worlds (run: pytest examples/test_my_filter.py)."""
import pytest

from estimators import make_filter
from slam import testing


@pytest.mark.parametrize("world,slot", [("tiny-planar", "srckf"), ("tiny-fixed-wing", "ins-srckf")])
def test_my_filter(world, slot, my_filter=lambda: make_filter("srckf")):  # the filter under test
    result = testing.run(world, [slot], using={"srckf": my_filter})  # in the place of srckf
    testing.no_divergence(result)
    testing.consistent(result)  # NEES and NIS in their chi-square bands over the runs
    testing.error_within(result, factor=3.0)  # within 3x the GTSAM smoother's error
    testing.agrees_with(result, slot, rtol=1e-9)  # the built-in srckf's errors, run by run
