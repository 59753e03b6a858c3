"""What the command line shows on the terminal besides the tables: the ``slam worlds``
listing wrapped to :data:`WIDTH` columns, and the campaign's progress bar with a total and
an ETA (:func:`progress_bar`)."""

from __future__ import annotations

import sys
import textwrap
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

WIDTH = 100
"""Columns of the terminal output (``slam worlds``, the result tables)."""


def world_lines(rows: Sequence[tuple[str, str, str]], width: int = WIDTH) -> list[str]:
    """``slam worlds``: name, kind and the description wrapped to ``width`` columns (the
    continuation lines indented under the description)."""
    nw = max(len(n) for n, _, _ in rows)
    kw = max(len(k) for _, k, _ in rows)
    indent = " " * (nw + kw + 4)
    out = []
    for name, kind, desc in rows:
        out += textwrap.wrap(desc or "-", width, initial_indent=f"{name:<{nw}}  {kind:<{kw}}  ",
                             subsequent_indent=indent, break_on_hyphens=False)
    return out



def expected_epochs(w, campaign: dict[str, Any]) -> int:
    """Filter epochs a campaign will run (every filter, every run, the first epoch of a
    run not counted), from the kind's cost of a run (``Kind.work``; for a world driven
    along a path an estimate, which the bar raises when it is passed)."""
    from slam.registry import get_kind

    per_run = next((s.n for s in get_kind(w.kind).work(w) if s.bound == "epochs"), 1.0)
    return max(1, round(campaign["runs"] * len(campaign["filters"]) * max(per_run - 1.0, 1.0)))


@contextmanager
def progress_bar(w, campaign: dict[str, Any], by_epochs: bool = True, file: Any = None,
                 disable: bool | None = None) -> Iterator[tuple[Any, Any, Any]]:
    """The campaign's progress bar with a total and an ETA: over the filter epochs (they
    move within a run) with the finished runs beside them, or - on a Dask cluster, whose
    workers report no epochs - over the runs.  Yields ``(bar, runs_done, epochs)``: the
    callbacks :func:`slam.campaign.run_campaign` takes.  ``file`` (default stderr) and
    ``disable`` (default: when ``file`` is not a terminal) as for ``tqdm``."""
    from tqdm import tqdm

    runs = campaign["runs"]
    done = [0]
    if not by_epochs:
        with tqdm(total=runs, desc=f"{w.name}: runs", unit="run", file=file or sys.stderr,
                  disable=disable) as bar:
            yield bar, bar.update, lambda n: None
        return
    fmt = ("{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} epochs "
           "[{elapsed}<{remaining}{postfix}]")
    with tqdm(total=expected_epochs(w, campaign), desc=f"{w.name}", unit="epoch",
              file=file or sys.stderr, disable=disable, bar_format=fmt) as bar:
        def show() -> None:
            bar.set_postfix_str(f"runs {done[0]}/{runs}", refresh=False)
            bar.refresh()

        def runs_done(k: int) -> None:
            done[0] += k
            if done[0] >= runs:  # finished: the bar ends full whatever the estimate was
                bar.total = max(bar.n, 1)
                bar.n = bar.total
            show()

        def epochs(n: int) -> None:
            if done[0] < runs:
                if n >= bar.total:  # the estimate was short: raise it
                    bar.total = int(n * 1.1) + 1
                bar.n = n
            show()

        show()
        yield bar, runs_done, epochs
