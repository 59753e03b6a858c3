"""One header vocabulary across the kinds' terminal tables: the same quantity has the
same header in every kind (:data:`slam.render.tables.TERMINAL_HEADERS`), and a share of
epochs reads ``"97 %"`` everywhere."""

from __future__ import annotations

import re

import pytest

from slam.registry import KINDS
from slam.render.tables import TERMINAL_HEADERS

ENTRY = {"anees_steps_inside_95": 0.97, "anees_inside_95": 0.97, "runs_scored": 2,
         "diverged_runs": 0, "anees": 1.0, "anees_bounds_95": [0.5, 1.5]}


def summary(kind: str) -> dict:
    return {"world": "x", "kind": kind, "runs": 2, "seed": 0, "paper": {},
            "filters": {"ekf": dict(ENTRY), "srckf": dict(ENTRY)}, "baselines": {},
            "reference": {"gtsam": dict(ENTRY)}}


def headers(text: str) -> list[list[str]]:
    """The header cells of every plain table in ``text``: the columns are the runs of
    dashes under the header; a header may take several lines above them."""
    lines = text.split("\n")
    out = []
    for i, line in enumerate(lines):
        if not re.fullmatch(r"-+( {2}-+)+", line):
            continue
        spans = [m.span() for m in re.finditer(r"-+", line)]
        above = []
        for j in range(i - 1, max(i - 4, -1), -1):
            if not lines[j].strip():
                break
            above.insert(0, lines[j])
        out.append([" ".join(p for p in (a[lo:hi].strip() for a in above) if p)
                    for lo, hi in spans])
    return out


QUANTITY = [
    ("filter time per epoch", re.compile(r"ms/|µs|/cyc|time|/epoch")),
    ("diverged runs", re.compile(r"^div")),
    ("epochs in band", re.compile(r"(?<!ANEES )\bband\b")),
    ("verdict", re.compile(r"^verdict")),
]


def quantity_of(header: str) -> str | None:
    if header == TERMINAL_HEADERS["estimator time per run"]:
        return "estimator time per run"
    for name, pattern in QUANTITY:
        if pattern.search(header) and "ANEES" not in header:
            return name
    return None


@pytest.mark.parametrize("kind", list(KINDS))
def test_the_same_quantity_has_the_same_header_in_every_kind(kind: str) -> None:
    tables = headers(KINDS[kind].report.text_table(summary(kind)))
    assert tables, "no table found"
    found = {}
    for head in tables:
        for h in head:
            q = quantity_of(h)
            if q is not None:
                assert h == TERMINAL_HEADERS[q], f"{kind}: {q!r} is headed {h!r}"
                found[q] = h
    assert "diverged runs" in found or kind == "recorded-log"


@pytest.mark.parametrize("kind", list(KINDS))
def test_a_share_of_epochs_reads_with_a_space_before_the_percent_sign(kind: str) -> None:
    text = KINDS[kind].report.text_table(summary(kind))
    assert not re.search(r"\d%", text)
    if any("in band" in h for head in headers(text) for h in head):
        assert "97 %" in text


def test_a_stale_header_is_caught() -> None:
    """The checks above see a header of the old vocabulary."""
    text = ("estimator  ms/cycle  div\n---------  --------  ---\nekf           1.0  0/2\n")
    cells = headers(text)[0]
    assert cells == ["estimator", "ms/cycle", "div"]
    assert [quantity_of(h) for h in cells] == [None, "filter time per epoch", "diverged runs"]
    assert [TERMINAL_HEADERS[quantity_of(h)] for h in cells[1:]] == ["ms/epoch", "diverged"]
