"""The ``slam`` command line.

Exit codes: 0 success; 2 bad input (a clear message naming the file or option, the
key and the allowed range; nothing is written); 1 an unexpected error (a bug).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import click

from estimators import FILTER_NAMES


class InputError(click.ClickException):
    """Bad input from the user: exit code 2, nothing half-written."""

    exit_code = 2

    def show(self, file=None) -> None:
        click.echo(f"error: {self.format_message()}", err=True, file=file)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
def main() -> None:
    """Workbench for nonlinear navigation filters, scored against a GTSAM smoother."""


@main.command("worlds")
def worlds_cmd() -> None:
    """List the bundled worlds."""
    from worlds import list_worlds

    rows = list_worlds()
    width = max(len(n) for n, _, _ in rows)
    kwidth = max(len(k) for _, k, _ in rows)
    for name, kind, desc in rows:
        click.echo(f"{name:<{width}}  {kind:<{kwidth}}  {desc}")


def _parse_filters(value: str | None, world) -> list[str]:
    if value is None:
        return list(world.filters.names)
    names = [v.strip() for v in value.split(",") if v.strip()]
    bad = [n for n in names if n not in FILTER_NAMES]
    if not names or bad:
        raise InputError(f"--filters: unknown filter {', '.join(bad) or '(none)'}; "
                         f"allowed: {', '.join(FILTER_NAMES)} (comma-separated)")
    return names


@main.command("run")
@click.argument("world", required=False, default="bailey")
@click.option("--filters", "filters", metavar="NAMES",
              help="Comma-separated filters (default: the world's list), e.g. ekf,srckf.")
@click.option("--runs", type=int, help="Monte Carlo runs (default: the world's), 1 to 10000.")
@click.option("--seed", type=int, help="Campaign seed (default: the world's), >= 0.")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path),
              help="Output folder (default: out/<world>).")
@click.option("--workers", type=int, default=None,
              help="Local worker processes (default: number of cores, at most 2 per core).")
@click.option("--scheduler", metavar="ADDRESS",
              help="Send the runs to a Dask distributed scheduler (e.g. tcp://host:8786) "
                   "instead of the local pool; needs the [dask] extra.")
@click.option("--no-plots", is_flag=True, help="Skip the figures (faster).")
def run_cmd(world: str, filters: str | None, runs: int | None, seed: int | None,
            out: Path | None, workers: int | None, scheduler: str | None,
            no_plots: bool) -> None:
    """Run a Monte Carlo campaign on WORLD (a bundled name or a .toml path; default bailey)
    and write summary.json, report.md/.html, figures and TUM trajectories."""
    from worlds import WorldError, load_world

    try:
        w = load_world(world)
    except WorldError as exc:
        raise InputError(str(exc)) from None
    names = _parse_filters(filters, w)
    if runs is not None and not 1 <= runs <= 10000:
        raise InputError(f"--runs = {runs}: must be in [1, 10000]")
    if seed is not None and seed < 0:
        raise InputError(f"--seed = {seed}: must be >= 0")
    if workers is None:
        workers = os.cpu_count() or 1
    if not 1 <= workers <= 256:
        raise InputError(f"--workers = {workers}: must be in [1, 256]")
    out = out or Path("out") / w.name
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a folder")

    from tqdm import tqdm

    from .campaign import dask_mapper, run_campaign
    from .report import text_table, write_outputs

    mapper = client = None
    if scheduler:
        try:
            mapper, client = dask_mapper(scheduler)
        except (OSError, TimeoutError, ValueError, RuntimeError) as exc:
            raise InputError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
    n_runs = runs or w.runs
    t0 = time.perf_counter()
    try:
        with tqdm(total=n_runs, desc=f"{w.name}: runs", unit="run", file=sys.stderr,
                  disable=None) as bar:
            result = run_campaign(w, filters=names, runs=n_runs, seed=seed, workers=workers,
                                  mapper=mapper, progress=bar.update)
    finally:
        if client is not None:
            client.close()
    elapsed = time.perf_counter() - t0
    executor = f"dask scheduler {scheduler}" if scheduler else f"{workers} local worker(s)"
    write_outputs(result, out, plots=not no_plots)
    click.echo(text_table(result.summary))
    click.echo(f"\n{n_runs} runs x {len(names)} filters + baselines in {elapsed:.1f} s "
               f"on {executor}; results in {out}/")


if __name__ == "__main__":  # pragma: no cover
    main()
