"""The decision part of every kind's report and terminal output: the headline, one ranking
table per headline metric (rank, RMSE, paired ΔMSE ± s.e. against the best, its z and
verdict) and the filters' settings, from the ``ranking`` / ``headline`` / ``settings_text``
entries :func:`slam.decision.decide` put in the summary."""

from __future__ import annotations

import textwrap
from typing import Any

from slam.render.document import Section
from slam.render.tables import MISSING, TERMINAL_WIDTH, Column, num, plain_table

HEADER = ("rank", "filter", "RMSE", "ΔMSE vs best (± s.e.)", "ΔRMSE", "z", "verdict")


def delta_text(row: dict[str, Any], unit: str = "") -> str:
    """A ranking row's paired ΔMSE against the best: ``"+0.012 ± 0.003 m²"``, or with a
    single run (no standard error) ``"+0.012 m² (one run)"``."""
    sq = f" {unit}²" if unit else ""
    if row.get("delta_se") is None:
        return f"{row['delta_mse']:+.3g}{sq} (one run)"
    return f"{row['delta_mse']:+.3g} ± {row['delta_se']:.2g}{sq}"


def _cells(name: str, row: dict[str, Any], unit: str) -> list[str]:
    if row["verdict"] == "best":
        delta, pct, z = "best", "", ""
    else:
        delta = delta_text(row, unit)
        pct = f"{row['delta_percent']:+.1f} %"
        z = num(row.get("z"), ".1f")
    return [str(row["rank"]), name, f"{row['rmse']:#.4g} {unit}", delta, pct, z, row["verdict"]]


def rank_column(summary: dict[str, Any], metric: str, header: str = "rank") -> Column:
    """A results-table column with each filter's rank on the summary's ranking ``metric``
    (the missing mark for an estimator that is not ranked: a baseline, the smoother)."""
    rows = ((summary.get("ranking") or {}).get(metric) or {}).get("rows") or {}

    def cell(name: str, entry: dict[str, Any]) -> str:
        return str(rows[name]["rank"]) if name in rows else MISSING
    return Column(header, cell)


def ranking_rows(block: dict[str, Any]) -> list[list[str]]:
    """The ranking table of one metric (:data:`HEADER`), best first."""
    rows = block.get("rows") or {}
    return [_cells(n, rows[n], block["unit"]) for n in block.get("order", [])]


def _title(block: dict[str, Any]) -> str:
    if block.get("significance"):
        return f"{block['label']}: ranking on {block.get('runs', 0)} run ({block['significance']})"
    return (f"{block['label']}: paired ranking over {block.get('runs', 0)} runs "
            f"(significant: ΔMSE > {block['level_se']:g} s.e.; separated: > "
            f"{block['separated_se']:g} s.e.)")


def settings_rows(summary: dict[str, Any]) -> list[list[str]]:
    """``[filter, settings]`` of every filter that has tuning constants."""
    return [[n, e["settings_text"]] for n, e in (summary.get("filters") or {}).items()
            if e.get("settings_text")]


def decision_sections(summary: dict[str, Any]) -> list[Section]:
    """The report's decision sections: the headline, a ranking table per metric, the
    filters' settings."""
    out: list[Section] = []
    if summary.get("headline"):
        out.append(Section("Decision", text=summary["headline"]))
    for block in (summary.get("ranking") or {}).values():
        if "rows" in block:
            out.append(Section(f"Ranking: {_title(block)}", HEADER, ranking_rows(block)))
        else:
            out.append(Section(f"Ranking: {block['label']}",
                               text=f"No ranking: {block.get('reason', MISSING)}."))
    rows = settings_rows(summary)
    if rows:
        out.append(Section("Filter settings", ("filter", "settings"), rows, key_value=True,
                           text="Every tuning constant is stated in the world file "
                                "([filters.unscented], [filters.central_difference], ...)."))
    return out


def decision_text(summary: dict[str, Any], width: int = TERMINAL_WIDTH) -> str:
    """The terminal's decision block: each ranking as a compact table, the filters'
    settings and the headline, wrapped to ``width`` columns."""
    lines: list[str] = []
    for block in (summary.get("ranking") or {}).values():
        if "rows" not in block:
            continue
        lines += textwrap.wrap(_title(block), width) + [plain_table(HEADER, ranking_rows(block)),
                                                        ""]
    for name, text in settings_rows(summary):
        lines += textwrap.wrap(f"settings of {name}: {text}", width, subsequent_indent="  ")
    if summary.get("headline"):
        lines += [""] + textwrap.wrap(summary["headline"], width)
    return "\n".join(lines)


ORDERING_HEADER = ("paper's claim", "metric", "RMSE", "ΔMSE ± s.e.", "z", "runs", "verdict")


def ordering_rows(summary: dict[str, Any]) -> list[list[str]]:
    """One row per paper ordering tested in the summary's ``paper_ordering``
    (:func:`slam.ranking.ordering`): ``better`` beats ``worse``, with their RMSE and the
    paired ΔMSE (better − worse; negative agrees with the paper)."""
    rows = []
    for o in summary.get("paper_ordering") or []:
        unit = o["unit"]
        if o.get("verdict") is None:
            rows.append([f"{o['better']} beats {o['worse']}", o["label"], MISSING, MISSING,
                         MISSING, str(o.get("runs", 0)),
                         f"untested: {o.get('verdict_reason', MISSING)}"])
            continue
        rows.append([f"{o['better']} beats {o['worse']}", o["label"],
                     f"{o['rmse_better']:#.4g} vs {o['rmse_worse']:#.4g} {unit}",
                     f"{o['mean']:+.3g} ± {o['se']:.2g} {unit}²", num(o.get("z"), "+.1f"),
                     str(o["runs"]), o["verdict"]])
    return rows


def ordering_section(summary: dict[str, Any], text: str = "") -> Section | None:
    """The report section of the paper's orderings (``None`` when none was tested)."""
    rows = ordering_rows(summary)
    if not rows:
        return None
    rule = ("Paired over the runs both finished: ΔMSE is the mean of the per-run MSE "
            "difference (claimed better − claimed worse; negative agrees with the paper); "
            "'reproduced' when it is below −2 s.e., 'reversed' above +2 s.e.")
    return Section("The paper's ordering, tested", ORDERING_HEADER, rows,
                   f"{text} {rule}".strip())
