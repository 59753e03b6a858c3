"""The world-file reference, generated from the schema declarations.

Every key of a kind's schema (:mod:`worlds.schema` :class:`~worlds.schema.Field` and
:class:`~worlds.schema.Section` tables, as each kind's ``world.py`` declares them) becomes
one row: dotted key, unit (read off the key's name, which carries it), type, allowed
range, default and a one-line meaning.  The meanings live beside the declarations: the
keys every kind shares in :data:`COMMON`, a kind's own in ``DESCRIPTIONS`` of its
``keys`` module (``slam/kinds/<kind>/keys.py``).  :func:`missing_descriptions` lists the
keys without one (a test keeps it empty); :func:`markdown` renders the whole reference
(the docs build writes it to ``docs/generated/worlds.md``).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import worlds.common as wc
import worlds.schema as ws

UNITS: tuple[tuple[str, str], ...] = (
    ("_deg_h_sqrt_h", "°/h/√h"), ("_mg_sqrt_h", "mg/√h"), ("_mps_sqrt_h", "m/s/√h"),
    ("_deg_s_sqrt_hz", "°/s/√Hz"), ("_deg_sqrt_h", "°/√h"), ("_deg_h2", "(°/h)²"),
    ("_deg2", "°²"), ("_deg_s2", "°/s²"), ("_deg_s", "°/s"), ("_deg_h", "°/h"),
    ("_deg", "°"), ("_rad_s", "rad/s"), ("_rad", "rad"), ("_arcsec", "″"),
    ("_arcmin", "′"), ("_m_per_mps", "m/(m/s)"), ("_k_per_m", "1/m"), ("_per_s", "1/s"),
    ("_mps2", "m/s²"), ("_mps", "m/s"), ("_km", "km"), ("_rev_s", "rev/s"), ("_m", "m"),
    ("_s", "s"), ("_hz", "Hz"), ("_mg", "mg"), ("_g", "g (9.80665 m/s²)"), ("_nt", "nT"),
    ("_ut", "µT"), ("_percent", "%"), ("_steps", "control steps"),
)
"""Key-name suffix -> unit, longest first (a key's name carries its unit)."""

COMMON: dict[str, str] = {
    "kind": "the scenario kind this world is read as",
    "description": "one line shown by `slam worlds` and in the reports",
    "runs": "Monte Carlo runs of the campaign (`--runs` overrides)",
    "seed": "the campaign seed: run i draws from the i-th child of its SeedSequence",
    "paper": "free-form: the paper's reported numbers, passed through to summary.json",
    "filters.names": "the filters the campaign runs (`--filters` overrides)",
    "filters.association": "data association: the true landmark ids, or gated nearest "
                           "neighbour",
    "filters.gate_accept": "nearest neighbour: accept a match below this squared "
                           "Mahalanobis distance (NIS)",
    "filters.gate_new": "nearest neighbour: a new landmark when every NIS is above this",
    "filters.mode": "sigma points over the whole state (joint) or over the blocks a step "
                    "touches (local)",
    "filters.unscented": "settings table of the unscented filters: alpha, beta, kappa",
    "filters.central_difference": "settings table of the central-difference filters: h",
    "filters.hinf": "settings table of the H∞ filters: gamma, on_failure",
    "filters.homm": "settings table of the HoMM-UKF: moments, skewness, kurtosis",
    "filters.iterated": "settings table of the iterated filters: iterations, tolerance",
    "site.latitude_deg": "geodetic latitude of the site (sets the Earth rate and gravity)",
    "site.longitude_deg": "longitude of the site",
    "site.height_m": "height of the site above the ellipsoid",
    "scoring.divergence_deg": "a run whose final attitude error exceeds this counts as "
                              "diverged",
}
"""Meanings of the keys several kinds declare alike (a kind's ``DESCRIPTIONS`` may
override one)."""

SETTINGS: dict[str, str] = {
    "unscented.alpha": "spread of the scaled unscented points",
    "unscented.beta": "prior-knowledge weight on the centre point's covariance (2: Gaussian)",
    "unscented.kappa": 'secondary scaling; "3-n" is Julier\'s original set',
    "central_difference.h": "central-difference step (√3 is optimal for a Gaussian prior)",
    "hinf.gamma": "H∞ attenuation bound γ (inf: the Kalman twin)",
    "hinf.on_failure": 'when the Riccati existence condition fails: "raise" or fall back '
                       'to the "kalman" update (counted)',
    "homm.moments": 'where the HoMM rule takes the moments it matches: "predicted" '
                    '(the paper\'s) or "fixed"',
    "homm.skewness": "standardised third moment matched (0: Gaussian)",
    "homm.kurtosis": "standardised fourth moment matched (3: Gaussian)",
    "iterated.iterations": "most iterations of the iterated update (1: one pass)",
    "iterated.tolerance": "whitened step below which the iterations stop",
}
"""Meanings of the ``[filters.<table>]`` settings keys (:data:`worlds.common.RULE_SETTINGS`)."""


@dataclass(frozen=True)
class Row:
    """One key of the reference."""

    key: str
    unit: str
    type: str
    range: str
    default: str
    meaning: str


def walk(schema: Mapping[str, ws.Field | ws.Section], prefix: str = "",
         optional: bool = False) -> Iterator[tuple[str, ws.Field, bool]]:
    """``(dotted key, field, in an optional section)`` for every key of ``schema``."""
    for name, spec in schema.items():
        key = f"{prefix}{name}"
        if isinstance(spec, ws.Section):
            yield from walk(spec.schema, key + ".", optional or not spec.required)
        else:
            yield key, spec, optional


def unit_of(key: str) -> str:
    """The unit a key's name spells (``"—"`` when it spells none)."""
    last = key.rpartition(".")[2]
    for suffix, unit in UNITS:
        if last.endswith(suffix):
            return unit
    return "—"


def type_of(spec: ws.Field) -> str:
    """A field's TOML type in words."""
    if isinstance(spec, ws.Integer):
        return "integer"
    if isinstance(spec, ws.Number):
        return "number"
    if isinstance(spec, ws.Boolean):
        return "boolean"
    if isinstance(spec, ws.String):
        return "string"
    if isinstance(spec, ws.StringList):
        return "list of strings"
    if isinstance(spec, ws.Vector):
        return f"list of {spec.length} numbers"
    if isinstance(spec, ws.NumberList):
        return f"list of 1-{spec.max_len} numbers"
    if isinstance(spec, ws.Points):
        return "list of [x, y]"
    if isinstance(spec, wc.SettingsTable):
        return "table (settings)"
    if isinstance(spec, ws.FreeForm | ws.Table):
        return "table"
    doc = (type(spec).__doc__ or type(spec).__name__).strip().split("\n\n")[0]
    return " ".join(doc.split()).rstrip(".")


def range_of(spec: ws.Field) -> str:
    """A field's allowed values."""
    if isinstance(spec, ws.Number | ws.Integer | ws.Vector | ws.NumberList):
        return str(spec.interval)
    if isinstance(spec, ws.String) and spec.choices is not None:
        return " \\| ".join(f'"{c}"' for c in spec.choices)
    if isinstance(spec, ws.StringList):
        return ", ".join(spec.choices)
    if isinstance(spec, ws.String):
        return f"≤ {spec.max_len} characters" + (", one line" if spec.one_line else "")
    if isinstance(spec, wc.SettingsTable):
        return ", ".join(wc.RULE_SETTINGS[spec.table])
    return "—"


def default_of(spec: ws.Field, optional: bool) -> str:
    """A field's default as written in the file (``required`` when it has none)."""
    d = spec.default
    if d is ws.REQUIRED:
        return "required in its section" if optional else "required"
    if d is None:
        return "none"
    if callable(d):
        return ws.format_value(d())
    if isinstance(d, float) and math.isinf(d):
        return "inf"
    return ws.format_value(d)


def rows(schema: Mapping[str, ws.Field | ws.Section], descriptions: Mapping[str, str]
         ) -> list[Row]:
    """The reference rows of one kind's schema (meanings from ``descriptions``, then
    :data:`COMMON`; ``""`` when neither has one)."""
    return [Row(key, unit_of(key), type_of(spec), range_of(spec), default_of(spec, opt),
                descriptions.get(key, COMMON.get(key, "")))
            for key, spec, opt in walk(schema)]


def missing_descriptions(schema: Mapping[str, ws.Field | ws.Section],
                         descriptions: Mapping[str, str]) -> list[str]:
    """The keys of ``schema`` without a one-line meaning."""
    return [r.key for r in rows(schema, descriptions) if not r.meaning.strip()]


def stale_descriptions(schema: Mapping[str, ws.Field | ws.Section],
                       descriptions: Mapping[str, str]) -> list[str]:
    """The described keys that ``schema`` no longer declares."""
    keys = {key for key, _, _ in walk(schema)}
    return sorted(set(descriptions) - keys)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ") if "\\|" not in text else text


def table(found: list[Row]) -> str:
    """``found`` as a Markdown table."""
    head = "| key | unit | type | allowed | default | meaning |\n|---|---|---|---|---|---|\n"
    return head + "".join(
        f"| `{r.key}` | {r.unit} | {_cell(r.type)} | {_cell(r.range)} | "
        f"{_cell(r.default)} | {_cell(r.meaning)} |\n" for r in found)


def settings_rows() -> list[Row]:
    """The ``[filters.<table>]`` settings keys (:data:`worlds.common.RULE_SETTINGS`)."""
    return [Row(f"filters.{t}.{k}", "—", type_of(spec), range_of(spec), "required in its table",
                SETTINGS.get(f"{t}.{k}", ""))
            for t, keys in wc.RULE_SETTINGS.items() for k, spec in keys.items()]
