"""World noise that underflows (:class:`worlds.schema.Sigma`): a σ, noise density or
variance whose square in SI units is below :data:`worlds.limits.MIN_VARIANCE` is refused
on load, naming the key - before, a σ of 1e-300 built a covariance of 0 outside the filter
loop and ``NotPositiveDefiniteError`` escaped (alignment's velocity σ, fixed-wing's EA σ).
A σ of 0 stays allowed where it was."""

from __future__ import annotations

import importlib
import re
import tomllib
from importlib.resources import files

import pytest

import worlds.schema as ws
from slam.registry import world_from_dict
from tests.small_worlds import overridden
from worlds import WorldError, limits

#: kind module -> a bundled world of it
BUNDLED = {"planar": "bailey", "drone": "drone", "attitude": "star-sensor", "ship": "ship",
           "spinning": "spinning", "alignment": "alignment", "fixed_wing": "fixed-wing"}
#: key names that hold a σ, a noise density or a variance
NOISY = re.compile(r"sigma|noise|arw|_rw_|white|vrw|_var_|markov_(deg|g)\b|gamma")


def _keys(schema, prefix=""):
    for key, spec in schema.items():
        if isinstance(spec, ws.Section):
            yield from _keys(spec.schema, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", spec


def _doc(module: str, **dotted) -> dict:
    raw = (files("worlds") / f"{BUNDLED[module]}.toml").read_text(encoding="utf-8")
    return overridden(tomllib.loads(raw), dotted)


def _schema(module: str):
    return importlib.import_module(f"slam.kinds.{module}.world").SCHEMA


CASES = [(m, key, spec) for m in BUNDLED for key, spec in _keys(_schema(m))
         if isinstance(spec, ws.Sigma | ws.SigmaVector)]


def test_every_noise_key_is_checked_for_underflow():
    """A σ-like key of any kind that is a plain Number would let 1e-300 through."""
    plain = [f"{m}: {key}" for m in BUNDLED for key, spec in _keys(_schema(m))
             if isinstance(spec, ws.Number | ws.Vector) and NOISY.search(key.rpartition(".")[2])
             and not isinstance(spec, ws.Sigma | ws.SigmaVector)
             and not (spec.interval.lo > 0 and not spec.interval.lo_open
                      and (spec.interval.lo * spec.scale) ** 2 >= limits.MIN_VARIANCE)]
    assert plain == []
    assert len(CASES) >= 45


@pytest.mark.parametrize(("module", "key", "spec"), CASES,
                         ids=[f"{m}:{k}" for m, k, _ in CASES])
def test_an_underflowing_noise_is_a_world_error_naming_the_key(module, key, spec):
    tiny = 1e-300
    value = [tiny] * spec.length if isinstance(spec, ws.Vector) else tiny
    with pytest.raises(WorldError) as err:
        world_from_dict(_doc(module, **{key: value}), source="w.toml")
    text = str(err.value)
    shown = ws.format_key(f"{key}[0]" if isinstance(spec, ws.Vector) else key)
    assert text.startswith(f"w.toml: {shown} = 1e-300: must be ") and "\n" not in text
    assert "underflows in the filters" in text
    if 0.0 in spec.interval and not isinstance(spec, ws.Vector):
        world_from_dict(_doc(module, **{key: 0.0}))  # 0 (no noise) is still allowed


@pytest.mark.parametrize(("module", "key", "spec"), CASES,
                         ids=[f"{m}:{k}" for m, k, _ in CASES])
def test_a_noise_the_unit_conversion_rounds_to_zero_is_refused(module, key, spec):
    """The smallest subnormal, 5e-324 in the file's unit, times a unit factor below 1 is
    0 in SI units: still a σ given as non-zero (found by the fuzz harness: a star sensor σ
    of 5e-324 arcsec passed as 0 and raised in the filters' models)."""
    tiny = 5e-324
    value = [tiny] * spec.length if isinstance(spec, ws.Vector) else tiny
    with pytest.raises(WorldError, match="underflows in the filters"):
        world_from_dict(_doc(module, **{key: value}), source="w.toml")


def test_the_issue_cases_name_the_key_and_the_smallest_value():
    with pytest.raises(WorldError) as err:
        world_from_dict(_doc("alignment", **{"filters.velocity_sigma_mps": 1e-300}),
                        source="a.toml")
    assert str(err.value) == ("a.toml: [filters] velocity_sigma_mps = 1e-300: must be at least "
                              "1e-100 (below, its σ² in SI units is under 1e-200 and "
                              "underflows in the filters)")
    with pytest.raises(WorldError, match=r"\[ea\] roll_pitch_sigma_deg = 1e-300: must be at "
                                         r"least 5.73e-99 "):
        world_from_dict(_doc("fixed_wing", **{"ea.roll_pitch_sigma_deg": 1e-300}))
    # a σ whose square is subnormal (not 0) is refused too; the smallest allowed one loads
    with pytest.raises(WorldError, match="velocity_sigma_mps = 1e-160"):
        world_from_dict(_doc("alignment", **{"filters.velocity_sigma_mps": 1e-160}))
    world_from_dict(_doc("alignment", **{"filters.velocity_sigma_mps": 1e-100}))
    # a variance key's floor is the variance itself
    with pytest.raises(WorldError, match=r"initial_attitude_var_deg2 = 1e-300: must be at "
                                         r"least 3.28e-197 .*its variance"):
        world_from_dict(_doc("attitude", **{"filters.initial_attitude_var_deg2": 1e-300}))
    # an H∞ bound whose 1/γ² would overflow
    with pytest.raises(WorldError, match=r"\[sweep\] gammas_rad\[1\] = 1e-300"):
        world_from_dict(_doc("spinning", **{"sweep.gammas_rad": [2.0, 1e-300]}))
