"""The free-form ``[paper]`` table (:class:`worlds.schema.Paper`): the keys a kind's report
reads are checked by type on load (a one-line error before any run); any other key of
any type passes through and every kind's report renders it.  Before (issue 24), a number
where a report expected text (spinning's ``best_pitch = 5``) raised ``AttributeError`` in
``slam/render/tables.py`` after the whole campaign had run."""

from __future__ import annotations

import tomllib
from importlib.resources import files

import pytest

from slam.registry import KINDS, world_from_dict
from slam.render.document import sections_markdown
from slam.render.tables import html_table, paper_range, plain_table
from tests.small_worlds import overridden
from worlds import WorldError

BUNDLED = {"planar-slam": "bailey", "drone-slam": "drone", "attitude": "star-sensor",
           "ship": "ship", "spinning": "spinning", "alignment": "alignment",
           "fixed-wing": "fixed-wing"}


def _doc(kind: str, **dotted) -> dict:
    raw = (files("worlds") / f"{BUNDLED[kind]}.toml").read_text(encoding="utf-8")
    return overridden(tomllib.loads(raw), {f"paper.{k}": v for k, v in dotted.items()})


WRONG = [
    ("planar-slam", "filters.srckf.pos_err_range_m.x", "wide",
     '[paper.filters.srckf.pos_err_range_m] x = "wide": must be a list of 2 numbers'),
    ("planar-slam", "filters", 5,
     "[paper] filters = 5: must be a table (the report reads *.pos_err_range_m.* in it)"),
    ("drone-slam", "filters.srukf.pos_err_range_m.z", [1.0, "a"],
     '[paper.filters.srukf.pos_err_range_m] z[1] = "a": must be a number'),
    ("attitude", "filters.srckf.roll_arcsec", "3",
     '[paper.filters.srckf] roll_arcsec = "3": must be a number'),
    ("attitude", "large_error", "fast",
     '[paper] large_error = "fast": must be a table (the report reads statement in it)'),
    ("ship", "claims.ukf.yaw_within_arcmin", "40",
     '[paper.claims.ukf] yaw_within_arcmin = "40": must be a number'),
    ("ship", "claims.cdkf.yaw", 5, "[paper.claims.cdkf] yaw = 5: must be a string"),
    ("spinning", "best_pitch", 5, "[paper] best_pitch = 5: must be a string"),
    ("alignment", "claims.uthinf.settle_within_s", "50",
     '[paper.claims.uthinf] settle_within_s = "50": must be a number'),
    ("alignment", "claims", 1,
     "[paper] claims = 1: must be a table (the report reads ukf.east in it)"),
    ("fixed-wing", "table1.ckf", 4,
     "[paper.table1] ckf = 4: must be a table (the report reads longitude_m in it)"),
    ("fixed-wing", "table1.ukf.heading_deg", [2.8],
     "[paper.table1.ukf] heading_deg = [2.8]: must be a number"),
] + [(kind, "source", 5, "[paper] source = 5: must be a string") for kind in BUNDLED]


@pytest.mark.parametrize(("kind", "key", "value", "message"), WRONG,
                         ids=[f"{k}:{key}" for k, key, _, _ in WRONG])
def test_a_wrong_typed_paper_key_the_report_reads_is_refused_on_load(kind, key, value, message):
    with pytest.raises(WorldError) as err:
        world_from_dict(_doc(kind, **{key: value}), source="w.toml")
    assert str(err.value) == f"w.toml: {message}"


@pytest.mark.parametrize("kind", list(BUNDLED))
def test_a_paper_table_that_is_not_a_table_is_refused(kind):
    doc = _doc(kind)
    doc["paper"] = [1, 2]
    with pytest.raises(WorldError, match=r"^w\.toml: paper = \[1, 2\]: must be a table$"):
        world_from_dict(doc, source="w.toml")


def _render(kind: str, summary: dict) -> str:
    sections = KINDS[kind].report.sections(summary)
    for sec in sections:
        if sec.header is not None:
            plain_table(sec.header, sec.rows)
            html_table(sec.header, sec.rows)
    return sections_markdown(sections)


@pytest.mark.parametrize("kind", list(BUNDLED))
def test_any_other_paper_key_of_any_type_loads_and_renders(kind):
    """Untyped keys pass through (a free-form table); every kind's report renders the
    summary's ``paper`` with them, beside filter entries that have run."""
    junk = {"extra": [1, {"a": True}], "count": 3, "note2": {"deep": [[1.5]]}}
    world = world_from_dict(_doc(kind, **junk))
    assert {k: world.paper[k] for k in junk} == junk
    names = {*world.filters.names, "uthinf", "ukf", "srckf", "hommukf", "cdkf", "ins-ukf",
             "ins-ckf"}
    summary = {"paper": world.paper, "runs": 1, "kind": kind,
               "filters": {n: {"runs_scored": 1} for n in names}}
    text = _render(kind, summary)
    assert "aper vs ours" in text  # the section that reads the paper table is there


def test_the_shared_renderers_take_a_paper_that_was_never_validated():
    """A summary built elsewhere (not through the schema): the shared table code shows a
    non-text cell as JSON, and the shared paper-range readers skip what is not a table or
    a pair of numbers (the kinds' own readers rely on the load-time types above)."""
    bad = {"best_pitch": 5, "worst_pitch": [1, 2], "blind_area": {"a": 1}, "source": 7}
    text = _render("spinning", {"paper": bad, "runs": 1, "filters": {}})
    assert '| blind area | {"a": 1} |' in text
    for paper in ({"filters": 3}, {"filters": {"srckf": 4}},
                  {"filters": {"srckf": {"pos_err_range_m": {"x": ["a", "b"]}}}}):
        for kind in ("planar-slam", "drone-slam"):
            _render(kind, {"paper": paper, "runs": 1, "filters": {"srckf": {}}})
        assert paper_range({"paper": paper}, "srckf", "x") is None
