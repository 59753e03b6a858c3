"""What several world kinds declare alike: the whole-world table (:func:`world`) and the
fields every validated world has (:class:`WorldBase`), the sampled-sensor and
joint-filter mixins of their section dataclasses and the world properties counting
samples and epochs, the checks across keys that recur (a rate dividing another, a
duration of whole periods, one value below another), and the key specs that recur
(noise densities, prior σ, the divergence bound), the whole of a ``parse`` that checks
nothing else (:func:`parse_checked`), and the work of a run sampled at fixed rates
(:func:`rate_work`)."""

from __future__ import annotations

import math
import operator
from collections.abc import Iterator, Sequence
from dataclasses import KW_ONLY, dataclass, field
from typing import Any

import worlds.schema as ws
from estimators.filters import SETTINGS, describe_settings, make_filter
from estimators.hinf import MIN_GAMMA
from estimators.homm import MOMENT_SOURCES
from estimators.rules import JULIER_KAPPA
from worlds import limits
from worlds.units import DEG, DEG_H


def world(kind: str, into: type, sections: dict[str, ws.Field | ws.Section],
          paper: dict[str, ws.Field] | None = None) -> ws.Section:
    """The whole table of a world kind, built into ``into`` (a :class:`WorldBase`): the
    header keys (:func:`~worlds.schema.header`), the kind's ``sections`` and last the
    free-form ``paper`` table (the paper's claims, passed through to summary.json), whose
    keys that the kind's report reads have the types ``paper`` gives
    (:class:`~worlds.schema.Paper`; ``source`` is text in every kind)."""
    typed = {"source": ws.TEXT, **(paper or {})}
    return ws.Section({**ws.header(kind), **sections, "paper": ws.Paper(typed)}, into=into)


PAPER_RANGES = {"filters.*.pos_err_range_m.*": ws.PAIR}
"""The ``[paper]`` keys the planar and drone reports read: each filter's quoted error
range ``[lo, hi]`` (m) per axis (:func:`slam.render.tables.paper_rows`, the figures)."""


@dataclass(frozen=True)
class WorldBase:
    """The fields of every validated world: its name and the header keys (``kind``,
    ``description``, ``runs``, ``seed``), the free-form ``paper`` table (JSON-compatible;
    treat it as read-only) and ``source``.  A kind's sections follow ``runs``; ``seed``,
    ``paper`` and ``source`` are keyword-only."""

    name: str
    kind: str
    description: str
    runs: int
    _: KW_ONLY
    seed: int = 0
    paper: dict[str, Any] = field(default_factory=dict)
    source: str = ""
    """Where the world came from (file path as shown in errors, or ``<name>``)."""


class Sampled:
    """Mixin of a sensor section sampled at ``rate_hz``: its sample period ``dt_s``."""

    rate_hz: float

    @property
    def dt_s(self) -> float:
        return 1.0 / self.rate_hz


class JointOnly:
    """Mixin of a ``[filters]`` section whose filters run on one joint state (no map to
    split): ``mode`` is always ``"joint"`` (read by the command line for every kind)."""

    @property
    def mode(self) -> str:
        return "joint"


def parse_checked(world: ws.Section, rules: Sequence[ws.Rule], data: dict[str, Any], name: str,
                  source: str) -> Any:
    """Read a parsed TOML document ``data`` against the table ``world`` (:func:`world`),
    make the checks across keys ``rules`` in order and build the world: a kind's ``parse``
    when the schema and its rules are all it checks (``source`` is shown in errors)."""
    root = ws.Where(source, "")
    v = ws.read_table(data, world.schema, root)
    ws.check_rules(rules, v, root)
    return ws.build(world, v, name=name, source=source)


def per_epoch(fast: str, slow: str, doc: str) -> property:
    """A world's property: samples of its section ``fast`` per period of its section
    ``slow`` (each with a ``rate_hz``; a whole number, checked on load)."""
    return property(lambda w: round(getattr(w, fast).rate_hz / getattr(w, slow).rate_hz),
                    doc=doc)


def epoch_count(section: str, doc: str) -> property:
    """A world's property: the epochs of its section ``section`` over ``duration_s``, the
    first at t = 0."""
    return property(lambda w: 1 + round(getattr(w, section).rate_hz * w.duration_s), doc=doc)


def divides_rate(key: str, other: str, sensor: str) -> ws.Rule:
    """The rate at ``key`` goes into the ``sensor``'s rate at ``other`` a whole number of
    times."""
    return ws.Rule(key, other, ws.whole_times,
                   f"must divide the {sensor} rate ({{limit:g}} Hz) a whole number of times")


def whole_periods_of(rate_key: str, what: str, key: str = "duration_s") -> ws.Rule:
    """The time at ``key`` is a whole number (>= 1) of periods of the ``what`` rate at
    ``rate_key``."""
    return ws.Rule(key, rate_key, ws.whole_periods,
                   lambda rate: f"must be a whole number (>= 1) of {what} periods ({1 / rate:g} s)")


def below(key: str, other: str) -> ws.Rule:
    """The value at ``key`` is below the one at ``other``."""
    return ws.Rule(key, other, operator.lt, "must be below {other} ({limit:g})")


def nonnegative(hi: float, scale: float, attr: str, default: Any = ws.REQUIRED) -> ws.Sigma:
    """A σ in ``[0, hi]`` (file units) times ``scale``, filling the field ``attr``: the
    shape of a sensor's noise densities and bias spreads (0: none; a non-zero one whose
    square underflows is refused, :class:`~worlds.schema.Sigma`)."""
    return ws.Sigma(ws.Interval(0.0, hi), default, scale).to(attr)


def divergence(default_deg: float) -> ws.Number:
    """The ``[scoring] divergence_deg`` key (filling ``divergence_rad``): a run whose final
    angle error exceeds it counts as diverged."""
    return ws.Number(ws.positive(180.0), default=default_deg, scale=DEG).to("divergence_rad")


def attitude_sigma(attr: str, hi_deg: float = 45.0) -> ws.Vector:
    """A filter's prior attitude σ per axis, in [0.01, ``hi_deg``] degrees in the file,
    filling the field ``attr`` in radians."""
    return ws.Vector(3, ws.Interval(0.01, hi_deg), scale=DEG).to(attr)


def bias_sigma(hi_deg_h: float) -> ws.Number:
    """The ``initial_bias_sigma_deg_h`` key: a filter's prior gyro-bias σ (deg/h in the
    file, at most ``hi_deg_h``), filling ``initial_bias_sigma_rad_s``."""
    return ws.Sigma(ws.positive(hi_deg_h), scale=DEG_H).to("initial_bias_sigma_rad_s")


def rate_work(duration_s: float, samples: tuple[str, str, float], epochs: tuple[str, str, float],
              state: int, noise: int) -> Iterator[limits.Size]:
    """The work of a run of ``duration_s`` seconds whose sensor is sampled at a fixed rate
    and whose filters update at another (:mod:`worlds.limits`): ``samples`` and
    ``epochs`` are ``(key of the rate, what is counted, rate in Hz)``; ``state`` the
    filter state's dimension (a constant of the kind) and ``noise`` its process-noise
    inputs.  Samples ``duration × rate``, epochs ``duration × rate + 1`` (the first at
    t = 0), filter work :func:`~worlds.limits.filter_work`."""
    (s_key, s_what, s_rate), (e_key, e_what, e_rate) = samples, epochs
    n = duration_s * s_rate
    yield limits.Size("samples", s_what, n, s_key, f"duration_s = {duration_s:g} at {s_rate:g} Hz")
    m = duration_s * e_rate + 1
    yield limits.Size("epochs", e_what, m, e_key, f"duration_s = {duration_s:g} at {e_rate:g} Hz")
    yield limits.Size("state", "state dimensions", state, None)
    yield limits.Size("work", "units of filter work", limits.filter_work(m, n, state, noise),
                      s_key, f"{limits.count(m)} epochs, {limits.count(n)} samples, state "
                      f"{state}, {noise} noise inputs")


# --- filter settings ---------------------------------------------------------------------

class Kappa(ws.Field):
    """The unscented κ: a number in [-100, 100] or the string ``"3-n"`` (κ = 3 − n in
    every dimension, Julier's original set)."""

    def __init__(self) -> None:
        self.default = ws.REQUIRED

    def parse(self, value: Any, where: ws.Where) -> float | str:
        if isinstance(value, str):
            if value != JULIER_KAPPA:
                raise where.error(f'must be a number in [-100, 100] or "{JULIER_KAPPA}"', value)
            return value
        return ws.Number(ws.Interval(-100.0, 100.0)).parse(value, where)


RULE_SETTINGS: dict[str, dict[str, ws.Field]] = {
    "unscented": {"alpha": ws.Number(ws.Interval(1e-4, 10.0)),
                  "beta": ws.Number(ws.Interval(-10.0, 10.0)),
                  "kappa": Kappa()},
    "central_difference": {"h": ws.Number(ws.Interval(1.0, 10.0))},
    "hinf": {"gamma": ws.Number(ws.Interval(MIN_GAMMA, math.inf)),
             "on_failure": ws.String(choices=("raise", "kalman"))},
    "homm": {"moments": ws.String(choices=MOMENT_SOURCES),
             "skewness": ws.Number(ws.Interval(-10.0, 10.0)),
             "kurtosis": ws.Number(ws.Interval(1.0, 100.0))},
    "iterated": {"iterations": ws.Integer(ws.Interval(1, 100)),
                 "tolerance": ws.Number(ws.Interval(0.0, 1.0))},
}
"""The ``[filters.<table>]`` settings tables and their keys (the names of
:func:`estimators.make_filter`'s settings; every key required once the table is given)."""

FAMILY_OF_SETTING = {key: table for table, keys in RULE_SETTINGS.items() for key in keys}


def tables_of(base: str) -> tuple[str, ...]:
    """The settings tables filter ``base`` (a :func:`~estimators.make_filter` name) needs."""
    return tuple(dict.fromkeys(FAMILY_OF_SETTING[s] for s in SETTINGS[base]))


def base_filter(name: str) -> str:
    """The :func:`~estimators.make_filter` name inside a workbench filter name: the first
    dash- or colon-separated part that is one (``ea-ukf`` -> ``ukf``, ``srukf-inv`` ->
    ``srukf``, ``ukf:additive`` -> ``ukf``); ``name`` itself if none is."""
    for part in name.replace(":", "-").split("-"):
        if part in SETTINGS:
            return part
    return name


class SettingsTable(ws.Field):
    """An optional ``[filters.<table>]`` table of filter settings (:data:`RULE_SETTINGS`):
    ``None`` when absent, else a dict of its checked keys (all required)."""

    def __init__(self, table: str) -> None:
        self.table, self.default = table, None

    def parse(self, value: Any, where: ws.Where) -> dict[str, Any]:
        return ws.read_table(value, RULE_SETTINGS[self.table], where)


def settings_tables() -> dict[str, ws.Field]:
    """The settings tables a kind's ``[filters]`` section declares (each optional; which
    are required follows from the filters it runs: :func:`check_settings`)."""
    return {table: SettingsTable(table) for table in RULE_SETTINGS}


@dataclass(frozen=True)
class TunedFilters:
    """Mixin of a ``[filters]`` section with settings tables: the tables as read
    (``None`` when absent) and the filters built from them."""

    _: KW_ONLY
    unscented: dict[str, Any] | None = None
    central_difference: dict[str, Any] | None = None
    hinf: dict[str, Any] | None = None
    homm: dict[str, Any] | None = None
    iterated: dict[str, Any] | None = None

    def settings_of(self, name: str) -> dict[str, Any]:
        """The stated settings of workbench filter ``name`` (its base filter's keywords)."""
        out: dict[str, Any] = {}
        for table in tables_of(base_filter(name)):
            out.update(getattr(self, table) or {})
        return out

    def missing(self, names: Sequence[str]) -> tuple[str, list[str]] | None:
        """The first settings table that filters among ``names`` need and the world does
        not state, with those filters (``None`` when every one is stated)."""
        for table in RULE_SETTINGS:
            need = [n for n in names if table in tables_of(base_filter(n))]
            if need and getattr(self, table) is None:
                return table, need
        return None

    def make(self, name: str) -> Any:
        """The filter of workbench name ``name``: its base filter with the stated settings."""
        base = base_filter(name)
        return make_filter(base, **self.settings_of(name))

    def describe(self, name: str) -> str:
        """``name``'s settings in one line (:func:`estimators.describe_settings`)."""
        return describe_settings(self.make(name))


TABLE_KEYS = {"unscented": "alpha, beta, kappa (alpha = 1, beta = 2, kappa = 0 is the cubature "
              "point set; say which standard you take)",
              "central_difference": "h (sqrt(3) is optimal for a Gaussian prior)",
              "hinf": "gamma and on_failure",
              "homm": 'moments ("predicted": [Ding 2017]\'s, or "fixed"), skewness and kurtosis',
              "iterated": "iterations and tolerance"}


def check_settings(filters: Any, names: Sequence[str], where: ws.Where) -> None:
    """Raise at ``[filters.<table>]`` when a filter among ``names`` needs a settings table
    that ``filters`` (a :class:`TunedFilters` or its read values) does not state."""
    if isinstance(filters, dict):
        filters = TunedFilters(**{t: filters.get(t) for t in RULE_SETTINGS})
    gap = filters.missing(names)
    if gap is not None:
        table, need = gap
        raise where.child(table).error(
            f"missing (required by {', '.join(need)}: state {TABLE_KEYS[table]})")
