"""Markdown result tables for docs/results.md from campaign outputs.

Each input is a ``summary.json`` written by ``slam run WORLD --no-plots --out DIR`` (give the
folder or the file) or a JSON written by ``python -m benchmarks.separation WORLD --json
PATH`` (the drone kind, whose summary has no ranking).  Per world one table: per filter and
headline metric the RMSE, the rank and the paired ΔMSE ± s.e. against the best with
z = ΔMSE / s.e. (``slam.ranking``), then the ANEES with its 95 % band and the share of
epochs in band and the runs it diverged on; below it the paper's orderings as the campaign
tested them.

Run ``python -m benchmarks.results_tables OUT1 OUT2 ...``; prints Markdown.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

CONSISTENCY = {"alignment": "anees_level"}
"""The ANEES a kind's consistency verdict is taken on (default ``anees``)."""


def load(path: Path) -> dict[str, Any]:
    """A ``summary.json`` (or the folder holding one) or a separation JSON."""
    p = path / "summary.json" if path.is_dir() else path
    return json.loads(p.read_text(encoding="utf-8"))


def _g(x: float | None, fmt: str = ".4g") -> str:
    return "—" if x is None else format(x, fmt)


def _cell(block: Mapping[str, Any], name: str) -> str:
    r = block["rows"].get(name)
    if r is None:
        return "—"
    head = f"{_g(r['rmse'])} (#{r['rank']})"
    if r["verdict"] in ("best",):
        return f"**{head}** best"
    if r["verdict"] == "equal":
        return f"{head} equal"
    z = "" if r["z"] is None else f", z {r['z']:.1f}"
    return f"{head} {r['delta_mse']:+.3g} ± {_g(r['delta_se'], '.2g')}{z}"


def _anees(entry: Mapping[str, Any], key: str) -> str:
    val = entry.get(key)
    if val is None:
        return "—"
    band = entry.get(f"{key}_bounds_95")
    inside = entry.get(f"{key}_steps_inside_95", entry.get(f"{key}_inside_95"))
    b = f" [{band[0]:.2f}, {band[1]:.2f}]" if band else ""
    i = f", {100 * inside:.0f} %" if inside is not None else ""
    return f"{val:.3g}{b}{i}"


def _orderings(s: Mapping[str, Any]) -> list[str]:
    tests = s.get("paper_ordering") or s.get("paper_order") or []
    out = []
    if isinstance(tests, Mapping):  # the ship kind: pairs ``a`` before ``b``, per metric
        for p in tests.get("pairs", []):
            d = "—" if p.get("mean") is None else f"{p['mean']:+.3g} ± {_g(p.get('se'), '.2g')}"
            z = "" if p.get("z") is None else f", z {p['z']:.1f}"
            out.append(f"{p['metric']}: {p['a']} < {p['b']}: Δ {d}{z}, holds: {p['holds']} "
                       f"({p['runs']} runs)")
        out += [f"{k}: paper's ordering {' < '.join(tests.get('order', []))} reproduced: {v}"
                for k, v in (tests.get("reproduced") or {}).items()]
        return out
    for t in tests:
        se = t.get("se")
        mean = t.get("mean")
        d = "—" if mean is None else f"{mean:+.3g} ± {_g(se, '.2g')} {t.get('unit', '')}²"
        out.append(f"{t.get('metric', '')}: {t['better']} < {t['worse']}: Δ {d}, "
                   f"{t.get('verdict')} ({t.get('runs')} runs)")
    return out


def table(s: Mapping[str, Any]) -> str:
    """One world's Markdown table."""
    blocks = [b for b in (s.get("ranking") or {}).values() if isinstance(b, Mapping)
              and "rows" in b]
    entries = {**s.get("filters", {}), **{k: v for k, v in (s.get("anees") or {}).items()}}
    names = list(dict.fromkeys(n for b in blocks for n in b["order"])) or list(entries)
    key = CONSISTENCY.get(s.get("kind", ""), "anees")
    head = ["filter"] + [f"{b['label']} RMSE ({b['unit']}) (#rank) ΔMSE ± s.e." for b in blocks]
    head += [f"{key.replace('_', ' ')} [95 % band], in band", "diverged runs"]
    lines = [f"**{s['world']}** ({s['runs']} runs, seed {s.get('seed')})", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for n in names:
        e = entries.get(n, {})
        div = e.get("diverged_runs")
        lines.append("| " + " | ".join([n, *(_cell(b, n) for b in blocks), _anees(e, key),
                                        "—" if div is None else str(div)]) + " |")
    refs = [b.get("reference") for b in blocks if b.get("reference")]
    if refs:
        lines.append("")
        lines.append("Smoother (" + refs[0]["name"] + ") RMSE: " + ", ".join(
            f"{b['label']} {_g(b['reference'].get('rmse'))} {b['unit']}"
            for b in blocks if b.get("reference")) + ".")
    orders = _orderings(s)
    if orders:
        lines.append("")
        lines += [f"- {o}" for o in orders]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """Print the tables of the outputs given on the command line."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args:
        raise SystemExit("usage: python -m benchmarks.results_tables OUT [OUT ...]")
    print("\n\n".join(table(load(Path(a))) for a in args))


if __name__ == "__main__":
    main()
