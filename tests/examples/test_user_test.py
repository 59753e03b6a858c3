"""The user's test file (examples/test_my_filter.py, ≤ 15 lines) passes on a good filter and
fails with a clear message on a broken one: a filter that ignores its measurements (its
update returns the prediction) is caught by the error check, naming the figure, and by
the agreement check, naming the run and the epoch.  Also the tiny worlds' sizes: every
one well under a second of CPU per run (reported, not timed), and slam.testing's checks
failing as they should on made-up summaries."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

from estimators import make_filter
from slam import testing

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "test_my_filter.py"
CASES = [("tiny-planar", "srckf"), ("tiny-fixed-wing", "ins-srckf")]


def _example():
    spec = importlib.util.spec_from_file_location("user_test_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class IgnoresMeasurements:
    """A broken filter: the library's SRCKF whose update returns the prediction."""

    def __init__(self) -> None:
        self._f = make_filter("srckf")

    def __getattr__(self, name: str):
        return getattr(self._f, name)

    def update(self, belief, model, z):
        _, inn = self._f.update(belief, model, z)
        return belief, inn


def test_the_example_is_short():
    assert len(EXAMPLE.read_text(encoding="utf-8").splitlines()) <= 15


@pytest.mark.parametrize(("world", "slot"), CASES)
def test_the_users_test_passes_on_a_good_filter(world, slot):
    _example().test_my_filter(world, slot)  # its own default: the library's SRCKF


@pytest.mark.parametrize(("world", "slot"), CASES)
def test_the_users_test_fails_clearly_on_a_broken_filter(world, slot):
    with pytest.raises(AssertionError) as err:
        _example().test_my_filter(world, slot, my_filter=IgnoresMeasurements)
    text = str(err.value)
    assert re.search(rf"{re.escape(slot)}: .*(×|band)", text), text
    result = testing.run(world, [slot], using={"srckf": IgnoresMeasurements})
    with pytest.raises(AssertionError, match=rf"run 0: {re.escape(slot)} differs from "
                       rf"{re.escape(slot)} first at epoch \d+ \(t = "):
        testing.agrees_with(result, slot, rtol=1e-9)
    with pytest.raises(AssertionError, match=r"error above 3× the smoother's .*the error "
                       "figures"):
        testing.error_within(result, 3.0)


def test_the_tiny_worlds_run_every_kind_with_a_smoother():
    names = testing.tiny_worlds()
    kinds = {testing.tiny_world(n).kind for n in names}
    assert kinds == {"planar-slam", "attitude", "ship", "alignment", "fixed-wing"}
    with pytest.raises(ValueError, match="no tiny world 'huge'"):
        testing.tiny_world("huge")
