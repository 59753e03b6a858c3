"""The world-file reference: every key of every kind has a one-line meaning, no meaning
names a key the schema no longer declares, and the generated page lists every key."""

from __future__ import annotations

import pytest

import worlds.reference as wr
import worlds.schema as ws
from slam.registry import KINDS
from slam.render import reference

SCHEMAS = reference.kind_schemas()


def test_every_world_kind_is_in_the_reference() -> None:
    with_files = {k.name for k in KINDS.values() if k.open_log is None}
    assert {ks.kind for ks in SCHEMAS} == with_files


@pytest.mark.parametrize("ks", SCHEMAS, ids=lambda ks: ks.kind)
def test_every_key_has_a_description(ks: reference.KindSchema) -> None:
    assert wr.missing_descriptions(ks.schema, ks.descriptions) == []
    assert wr.stale_descriptions(ks.schema, ks.descriptions) == []


def test_every_settings_key_has_a_description() -> None:
    assert [r.key for r in wr.settings_rows() if not r.meaning] == []


def test_a_key_without_a_description_is_reported() -> None:
    schema = {"kind": ws.String(choices=("x",)),
              "box": ws.Section({"width_m": ws.Number(ws.positive(1.0)),
                                 "depth_m": ws.Number(ws.positive(1.0), default=0.5)})}
    assert wr.missing_descriptions(schema, {"box.width_m": "how wide"}) == ["box.depth_m"]
    assert wr.stale_descriptions(schema, {"box.height_m": "gone"}) == ["box.height_m"]


def test_the_page_lists_every_key_with_its_unit_range_and_default() -> None:
    page = reference.markdown()
    for ks in SCHEMAS:
        for key, _, _ in wr.walk(ks.schema):
            assert f"| `{key}` |" in page
    assert "| `vehicle.speed_mps` | m/s | number | (0, 50] | 3.0 |" in page
    assert "| `srchinf` | gamma, on_failure | `[filters.hinf]` |" in page


@pytest.mark.parametrize(("key", "unit"), [("gyro_arw_deg_sqrt_h", "°/√h"),
                                           ("gyro.bias_rw_deg_h_sqrt_h", "°/h/√h"),
                                           ("compliance_m_per_mps", "m/(m/s)"),
                                           ("speed_mps", "m/s"), ("loops", "—")])
def test_units_are_read_off_key_names(key: str, unit: str) -> None:
    assert wr.unit_of(key) == unit
