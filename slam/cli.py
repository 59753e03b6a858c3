"""The ``slam`` command line.

Exit codes: 0 success; 2 bad input (a clear message naming the file or option, the
key and the allowed range; nothing is written); 1 an unexpected error (a bug).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import click

from estimators import FILTER_NAMES
from worlds.planar import MODES


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
@click.option("--mode", type=click.Choice(MODES),
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
    run the filters and the smoother on a recorded log."""
    if log_file is not None:
        _run_log_cmd(log_file, world, filters, runs, seed, out, workers, scheduler, mode)
        return
    from worlds import WorldError, load_world

    try:
        w = load_world(world or "bailey")
    except WorldError as exc:
        raise InputError(str(exc)) from None
    world_mode = getattr(getattr(w, "filters", None), "mode", None)
    if mode is not None and mode != world_mode:
        if w.kind != "planar-slam":
            raise InputError(f"--mode {mode}: world {w.name} (kind {w.kind}) has no {mode} "
                             "mode; local mode is for planar-slam worlds")
        w = replace(w, filters=replace(w.filters, mode=mode))
        world_mode = mode
    names = _parse_filters(filters, w)
    if world_mode is not None:
        _check_mode(names, world_mode, "--filters" if filters else f"{w.source} [filters] names")
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
    in_mode = f" ({world_mode} mode)" if world_mode else ""
    click.echo(f"\n{n_runs} runs x {len(names)} filters + baselines{in_mode} "
               f"in {elapsed:.1f} s on {executor}; results in {out}/")


def _check_mode(names: list[str], mode: str, where: str) -> None:
    from .local import LOCAL_FILTERS

    if mode == "local":
        bad = [n for n in names if n not in LOCAL_FILTERS]
        if bad:
            raise InputError(f"{where}: {', '.join(bad)} has no local mode; local mode "
                             f"supports {', '.join(LOCAL_FILTERS)} (or use --mode joint)")


def _run_log_cmd(log_file: str, world: str | None, filters: str | None, runs: int | None,
                 seed: int | None, out: Path | None, workers: int | None,
                 scheduler: str | None, mode: str | None) -> None:
    """``slam run --log FILE``: filters + smoother on a recorded log, scored against the
    smoother; writes ``summary.json`` (atomically) and prints a table."""
    from .recorded import DEFAULT_FILTERS, LogFormatError, log_table, read_odometry_log, run_log

    for given, opt in ((world, "WORLD"), (runs, "--runs"), (seed, "--seed"),
                       (workers, "--workers"), (scheduler, "--scheduler")):
        if given is not None:
            raise InputError(f"{opt} does not apply to --log (a recorded log is one run)")
    mode = mode or "local"
    if filters is None:
        names = list(DEFAULT_FILTERS)
    else:
        names = [v.strip() for v in filters.split(",") if v.strip()]
        bad = [n for n in names if n not in FILTER_NAMES]
        if not names or bad:
            raise InputError(f"--filters: unknown filter {', '.join(bad) or '(none)'}; "
                             f"allowed: {', '.join(FILTER_NAMES)} (comma-separated)")
    _check_mode(names, mode, "--filters")
    out = out or Path("out") / Path(log_file).stem
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a folder")
    try:
        log = read_odometry_log(log_file)
    except LogFormatError as exc:
        raise InputError(f"--log {exc}") from None

    from threadpoolctl import threadpool_limits
    from tqdm import tqdm

    from .report import summary_json

    t0 = time.perf_counter()
    with tqdm(total=len(names) + 1, desc=f"{Path(log_file).name}: filters + smoother",
              unit="run", file=sys.stderr, disable=None) as bar, threadpool_limits(1):
        summary = run_log(log, names, mode=mode, progress=bar.update)
    elapsed = time.perf_counter() - t0
    _write_atomic(out / "summary.json", summary_json(summary))
    click.echo(log_table(summary))
    click.echo(f"\n{len(names)} filters ({mode} mode) + GTSAM smoother in {elapsed:.1f} s; "
               f"results in {out}/")


def _write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder + rename."""
    import tempfile

    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


if __name__ == "__main__":  # pragma: no cover
    main()
