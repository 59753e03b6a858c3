"""The ``slam`` command line.

Exit codes: 0 success; 2 bad input (a clear message naming the file or option, the
key and the allowed range; nothing is written); 1 an unexpected error (a bug).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import click

from estimators import FILTER_NAMES

ALL_MODES = ("joint", "local")


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
    from slam.registry import list_worlds

    rows = list_worlds()
    width = max(len(n) for n, _, _ in rows)
    kwidth = max(len(k) for _, k, _ in rows)
    for name, kind, desc in rows:
        click.echo(f"{name:<{width}}  {kind:<{kwidth}}  {desc}")


def _parse_filters(value: str | None, default: Sequence[str]) -> list[str]:
    if value is None:
        return list(default)
    names = [v.strip() for v in value.split(",") if v.strip()]
    bad = [n for n in names if n not in FILTER_NAMES]
    if not names or bad:
        raise InputError(f"--filters: unknown filter {', '.join(bad) or '(none)'}; "
                         f"allowed: {', '.join(FILTER_NAMES)} (comma-separated)")
    return names


@main.command("run")
@click.argument("world", required=False, default=None)
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
@click.option("--mode", type=click.Choice(ALL_MODES),
              help="Filter mode: joint (sigma points over the whole state) or local (over the "
                   "blocks a step touches; ekf, srckf, srukf, srcdkf). Default: the world's "
                   "[filters] mode; local for --log.")
@click.option("--log", "log_file", metavar="FILE",
              help="Run the filters and the GTSAM smoother on a recorded log in GTSAM's planar "
                   "text format (ODOMETRY/LANDMARK lines, e.g. victoria_park.txt) instead of a "
                   "world; the filters are scored against the smoother.")
def run_cmd(world: str | None, filters: str | None, runs: int | None, seed: int | None,
            out: Path | None, workers: int | None, scheduler: str | None,
            no_plots: bool, mode: str | None, log_file: str | None) -> None:
    """Run a Monte Carlo campaign on WORLD (a bundled name or a .toml path; default bailey)
    and write summary.json, report.md/.html, figures and TUM trajectories; or, with --log,
    run the filters and the smoother on a recorded log (one run)."""
    if log_file is not None:
        w, kind = _open_log(log_file, world, filters, runs, seed, workers, scheduler, mode)
        workers = 1
    else:
        w, kind = _open_world(world or "bailey", mode)
    names = _parse_filters(filters, w.filters.names)
    world_mode = getattr(w.filters, "mode", None) if kind.modes else None
    if world_mode is not None:
        _check_mode(kind, names, world_mode,
                    "--filters" if filters else f"{w.source} [filters] names")
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
    _run_and_write(w, kind, names, runs, seed, workers, scheduler, out, not no_plots,
                   world_mode)


def _open_world(name: str, mode: str | None):
    """Load WORLD and apply ``--mode``; -> (world, kind)."""
    from slam.registry import get_kind, load_world
    from worlds import WorldError

    try:
        w = load_world(name)
    except WorldError as exc:
        raise InputError(str(exc)) from None
    kind = get_kind(w.kind)
    world_mode = getattr(w.filters, "mode", None)
    if mode is not None and mode != world_mode:
        if mode not in kind.modes:
            has = (f"modes {', '.join(kind.modes)}" if kind.modes else "no filter modes")
            raise InputError(f"--mode {mode}: world {w.name} (kind {w.kind}) has {has}")
        w = replace(w, filters=replace(w.filters, mode=mode))
    return w, kind


def _open_log(log_file: str, world: str | None, filters: str | None, runs: int | None,
              seed: int | None, workers: int | None, scheduler: str | None,
              mode: str | None):
    """``--log FILE``: the log as a one-run world of the recorded-log kind."""
    from slam.kinds.recorded.log import LogFormatError
    from slam.registry import log_kind

    for given, opt in ((world, "WORLD"), (runs, "--runs"), (seed, "--seed"),
                       (workers, "--workers"), (scheduler, "--scheduler")):
        if given is not None:
            raise InputError(f"{opt} does not apply to --log (a recorded log is one run)")
    kind = log_kind()
    try:
        w = kind.open_log(Path(log_file), _parse_filters(filters, ()) or None, mode)
    except LogFormatError as exc:
        raise InputError(f"--log {exc}") from None
    return w, kind


def _run_and_write(w, kind, names: list[str], runs: int | None, seed: int | None,
                   workers: int, scheduler: str | None, out: Path, plots: bool,
                   world_mode: str | None) -> None:
    """Run the campaign (local pool or Dask), write the report folder, print the table."""
    from tqdm import tqdm

    from slam.campaign import dask_mapper, run_campaign
    from slam.render.output import write_outputs

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
    write_outputs(result, kind.report, out, plots=plots)
    click.echo(kind.report.text_table(result.summary))
    in_mode = f" ({world_mode} mode)" if world_mode else ""
    click.echo(f"\n{n_runs} run{'s' if n_runs != 1 else ''} x {len(names)} filters + "
               f"baselines{in_mode} in {elapsed:.1f} s on {executor}; results in {out}/")


def _check_mode(kind, names: list[str], mode: str, where: str) -> None:
    allowed = (kind.mode_filters or {}).get(mode)
    if allowed is not None:
        bad = [n for n in names if n not in allowed]
        if bad:
            raise InputError(f"{where}: {', '.join(bad)} has no {mode} mode; {mode} mode "
                             f"supports {', '.join(allowed)} (or use --mode joint)")


if __name__ == "__main__":  # pragma: no cover
    main()
