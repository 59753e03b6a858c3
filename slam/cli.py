"""The ``slam`` command line.

Exit codes: 0 success; 2 bad input - one line ``error: ...`` naming the file or option,
the key or line and the allowed range or reason (control characters escaped, long
tokens cut), and nothing is written; 130 (143) interrupted by Ctrl-C (SIGTERM), the
workers stopped and nothing half-written; 1 an unexpected error (a bug: a traceback).

This module is the one error boundary of the application: a world or log the user
gave that turns out unusable during a run (a waypoint the vehicle cannot reach, a
mesh that does not cover the map, ...) raises a :class:`~worlds.schema.WorldError` or a
``LogFormatError`` wherever it is found - in a worker process too, the errors pickle
intact - and becomes exit 2 here; numerical failures inside a run never get here (the
filters count them as divergences, the smoother as a failed reference).
"""

from __future__ import annotations

import os
import re
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import click

from slam.cli_errors import InputError, Interrupted, clean_message  # noqa: F401

ALL_MODES = ("joint", "local")


class _Command(click.Command):
    """Usage errors (an option's bad value, an unknown option) as one ``error:`` line."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        try:
            return super().parse_args(ctx, args)
        except click.UsageError as exc:
            raise InputError(f"{exc.format_message()} (see `slam {self.name} --help`)"
                             ) from None


class _Group(click.Group):
    """The ``slam`` group: one-line usage errors, Ctrl-C exits 130 wherever it lands."""

    command_class = _Command

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if not args:  # bare `slam`: the help, as click shows it
            click.echo(ctx.get_help())
            ctx.exit(0)
        try:
            return super().parse_args(ctx, args)
        except click.UsageError as exc:
            raise InputError(f"{exc.format_message()} (see `slam --help`)") from None

    def resolve_command(self, ctx: click.Context, args: list[str]):
        try:
            return super().resolve_command(ctx, args)
        except click.UsageError as exc:
            raise InputError(f"{exc.format_message()} (see `slam --help`)") from None

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True, **extra: Any):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, False, **extra)
        own_process = args is None  # the `slam` command itself, not a test runner
        if own_process and _preload_interrupted() is not None:
            Interrupted().show()
            _exit(128 + signal.SIGINT, fast=True)
        try:
            rv = super().main(args, prog_name, complete_var, False, **extra)
        except click.ClickException as exc:
            exc.show()
            _exit(exc.exit_code, fast=own_process and isinstance(exc, Interrupted))
        except (click.Abort, KeyboardInterrupt):
            Interrupted().show()
            _exit(128 + signal.SIGINT, fast=own_process)
        except BrokenPipeError:  # e.g. `slam worlds | head -1`
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)


def _preload_interrupted() -> int | None:
    """Import the command line's own modules with Ctrl-C held back (:func:`_held`)."""
    return _held(_import_core)


def _import_core() -> None:
    import slam.campaign  # noqa: F401  (the registry and every kind's world schema)
    import slam.render.output  # noqa: F401


def _held(load: Callable[[], Any]) -> int | None:
    """Run ``load`` (imports of numpy, SciPy, GTSAM, matplotlib) with SIGINT and SIGTERM
    held back: a ``KeyboardInterrupt`` raised inside a C extension's initialisation turns
    into an ``ImportError`` and can abort the interpreter.  -> the signal that arrived
    meanwhile, if any (the caller then stops at once)."""
    caught: list[int] = []
    old = {s: signal.signal(s, lambda signum, _frame: caught.append(signum))
           for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        load()
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)
    return caught[0] if caught else None


def _load_kind(kind, caught: dict[str, int], plots: bool = False) -> None:
    """Import the kind's run and report modules (deferred until a world of it is valid),
    and its figure modules (matplotlib) when ``plots``, with the signals held back; a
    signal meanwhile stops the command as it would have."""
    signum = _held(lambda: (kind.load(), kind.report.figures() if plots else None))
    if signum is not None:
        caught["signum"] = signum
        raise KeyboardInterrupt


def _exit(code: int, fast: bool = False) -> None:
    """Exit with ``code``; ``fast`` (an interrupt, clean-up done) skips the interpreter's
    teardown of the numerical libraries, which takes a second or more."""
    if fast:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


def _print_version(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    if value and not ctx.resilient_parsing:
        from slam.render.provenance import version_text

        click.echo(version_text())
        ctx.exit(0)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True,
              callback=_print_version,
              help="Show the version, git commit, Python and library versions, and exit.")
def main() -> None:
    """Workbench for nonlinear navigation filters, scored against a GTSAM smoother."""


@main.command("worlds")
def worlds_cmd() -> None:
    """List the bundled worlds."""
    from slam.registry import list_worlds
    from slam.terminal import world_lines

    for line in world_lines(list_worlds()):
        click.echo(line)


def _parse_filters(value: str | None, default: Sequence[str],
                   allowed: Sequence[str]) -> list[str]:
    """``--filters`` as a list of names, each one of the kind's ``allowed`` filters."""
    if value is None:
        return list(default)
    from worlds.schema import did_you_mean

    names = [v.strip() for v in value.split(",") if v.strip()]
    bad = [n for n in names if n not in allowed]
    if not names or bad:
        hint = did_you_mean(bad[0], allowed) if bad else ""
        raise InputError(f"--filters: unknown filter {', '.join(bad) or '(none)'}{hint}; "
                         f"allowed: {', '.join(allowed)} (comma-separated)")
    if len(set(names)) != len(names):
        raise InputError(f"--filters {value}: names a filter twice")
    return names


@contextmanager
def _stop_signals() -> Iterator[dict[str, int]]:
    """SIGTERM raises ``KeyboardInterrupt`` like Ctrl-C (so the same clean-up runs);
    yields ``{"signum": ...}`` of the signal that arrived."""
    caught = {"signum": int(signal.SIGINT)}

    def on_term(signum: int, frame: Any) -> None:
        caught["signum"] = signum
        raise KeyboardInterrupt

    try:
        old = signal.signal(signal.SIGTERM, on_term)
    except ValueError:  # not the main thread: leave the signals alone
        yield caught
        return
    try:
        yield caught
    finally:
        signal.signal(signal.SIGTERM, old)


@main.command("run")
@click.argument("world", required=False, default=None)
@click.option("--filters", "filters", metavar="NAMES",
              help="Comma-separated filters (default: the world's list), e.g. ekf,srckf.")
@click.option("--runs", type=int, help="Monte Carlo runs (default: the world's), 1 to 10000.")
@click.option("--seed", type=int, help="Campaign seed (default: the world's), >= 0.")
@click.option("--out", "out", type=click.Path(path_type=Path),
              help="Output folder (default: out/<world>, with the options that differ from "
                   "the world's in the name, e.g. out/bailey-runs3-local). Written only if "
                   "absent, empty or an earlier output of slam.")
@click.option("--workers", type=int, default=None,
              help="Local worker processes (default: number of cores, at most 2 per core).")
@click.option("--scheduler", metavar="ADDRESS",
              help="Send the runs to a Dask distributed scheduler (e.g. tcp://host:8786) "
                   "instead of the local pool; needs the [dask] extra.")
@click.option("--no-plots", is_flag=True, help="Skip the figures (faster).")
@click.option("--mode", type=click.Choice(ALL_MODES),
              help="Filter mode: joint (sigma points over the whole state) or local (over the "
                   "blocks a step touches; ekf, srckf, srukf, srcdkf and their -inv / -linv). "
                   "Default: the world's "
                   "[filters] mode; local for --log.")
@click.option("--executor", type=click.Choice(("batched", "per-run")), default="batched",
              show_default=True,
              help="batched: chunks of runs go through the filters at once (the runs as an "
                   "array axis; kinds without it run per run); per-run: one run per task, the "
                   "reference path. Both give the same numbers to round-off.")
@click.option("--online", is_flag=True,
              help="Also score iSAM2's current pose after every epoch (row isam2, the online "
                   "optimum) - planar and drone worlds (the world's [filters] online) and "
                   "recorded planar logs.")
@click.option("--fixed-lag", "fixed_lags", type=float, multiple=True, metavar="S",
              help="Also score a fixed-lag smoother of lag S seconds, in [0, 1e6] (row "
                   "fls-<S>s; repeatable) - planar worlds; adds to [filters] fixed_lags_s.")
@click.option("--log", "log_file", metavar="FILE",
              help="Run the filters and the GTSAM smoother on a recorded log instead of a "
                   "world: GTSAM's planar text format (ODOMETRY/LANDMARK lines, e.g. "
                   "victoria_park.txt; scored against the smoother), an attitude log in "
                   "GTSAM's EqFdata.csv layout (`--log eqf`: the file the gtsam wheel ships; "
                   "scored against its truth and the AHRS smoother), or an IMU + GNSS log: "
                   "'kitti' (GTSAM's bundled KITTI drive) or FILE.csv with its sidecar "
                   "FILE.toml (layout: python -m pydoc slam.kinds.ins_log).")
@click.option("--holdout", type=int, metavar="K",
              help="IMU + GNSS logs: withhold every K-th GNSS fix from every estimator and "
                   "score the position error there (from fix 60).")
@click.option("--outage", "outages", multiple=True, metavar="START:LENGTH",
              help="IMU + GNSS logs: drop every GNSS fix from START for LENGTH seconds (from "
                   "the first IMU stamp) and score the drift at the window's end; repeatable.")
@click.option("--tum", "tum", type=click.Choice(("run0", "all")), default="run0",
              show_default=True,
              help="TUM trajectory files (and covariance sidecars) of run 0, or of every run "
                   "(all: <name>.run<r>.tum; the runs keep their tracks and take the per-run "
                   "path).")
def run_cmd(world: str | None, filters: str | None, runs: int | None, seed: int | None,
            out: Path | None, workers: int | None, scheduler: str | None,
            no_plots: bool, mode: str | None, executor: str, online: bool,
            fixed_lags: tuple[float, ...], log_file: str | None,
            holdout: int | None = None, outages: tuple[str, ...] = (),
            tum: str = "run0") -> None:
    """Run a Monte Carlo campaign on WORLD (a bundled name or a .toml path; default bailey)
    and write summary.json, report.md/.html, figures and TUM trajectories; or, with --log,
    run the filters and the smoother on a recorded log (one run)."""
    with _stop_signals() as caught:
        try:
            _run(world, filters, runs, seed, out, workers, scheduler, no_plots, mode, log_file,
                 caught, executor, tum == "all", holdout, outages, online, fixed_lags)
        except KeyboardInterrupt:
            raise Interrupted(caught["signum"]) from None


def _run(world: str | None, filters: str | None, runs: int | None, seed: int | None,
         out: Path | None, workers: int | None, scheduler: str | None, no_plots: bool,
         mode: str | None, log_file: str | None, caught: dict[str, int],
         executor: str = "batched", tum_all: bool = False, holdout: int | None = None,
         outages: tuple[str, ...] = (), online: bool = False,
         fixed_lags: tuple[float, ...] = ()) -> None:
    """``slam run``: validate everything, prepare the output, run, write."""
    if log_file is None and (holdout is not None or outages):
        raise InputError(f"{'--holdout' if holdout is not None else '--outage'} applies to "
                         "an IMU + GNSS log only (--log kitti or --log FILE.csv)")
    if log_file is not None:
        w, kind = _open_log(log_file, world, filters, runs, seed, workers, scheduler, mode,
                            holdout, outages)
        workers, own_mode = 1, None if mode else getattr(w.filters, "mode", None)
    else:
        w, kind, own_mode = _open_world(world or "bailey", mode)
    from slam.kinds.planar.world import online_rows, with_online

    own_rows = online_rows(w.filters)
    try:
        w = with_online(w, online, fixed_lags)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    _load_kind(kind, caught, plots=not no_plots)
    names = _parse_filters(filters, w.filters.names, kind.filters)
    gap = w.filters.missing(names) if hasattr(w.filters, "missing") else None
    if gap is not None:  # a filter's tuning constants are never a hidden default
        table, need = gap
        raise InputError(f"{'--filters' if filters else w.source}: {', '.join(need)} need(s) "
                         f"[filters.{table}] settings, which {w.source} does not state")
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
    campaign = {"world": w.name, "source": w.source, "kind": w.kind, "runs": runs or w.runs,
                "seed": w.seed if seed is None else seed, "mode": world_mode,
                "filters": names, "executor": executor}
    if tum_all:
        campaign["tum"] = "all"
    rows = online_rows(w.filters)
    if rows:
        campaign["online"] = rows
    if out is None:
        own = {"runs": w.runs, "seed": w.seed, "mode": own_mode,
               "filters": None if log_file is not None and filters else list(w.filters.names),
               "online": own_rows}
        out = Path("out") / default_folder(w.name, campaign, own)
    _run_and_write(w, kind, campaign, workers, scheduler, out, not no_plots)


def _slug(name: str) -> str:
    """A world name as one safe folder name (no path separators, no leading dot)."""
    slug = re.sub(r"[^\w.+-]+", "_", name, flags=re.ASCII).lstrip("._")[:80]
    return slug or "world"


def default_folder(name: str, campaign: dict[str, Any], own: dict[str, Any]) -> str:
    """``<world>``, plus each setting of the campaign that differs from the world's own
    (``own``: runs, seed, mode, filters), so that another campaign on the world does not
    replace its main result: ``bailey``, ``bailey-runs3-local``, ``bailey-seed7-ekf+srckf``."""
    parts = [f"{key}{campaign[key]}" for key in ("runs", "seed")
             if campaign[key] != own[key]]
    if campaign["mode"] is not None and campaign["mode"] != own["mode"]:
        parts.append(campaign["mode"])
    if list(campaign["filters"]) != list(own["filters"] or ()):
        parts.append("+".join(campaign["filters"]))
    if campaign.get("online", []) != own.get("online", []):
        parts.append("+".join(campaign["online"]))
    return "-".join([_slug(name), *parts])[:160]


def _open_world(name: str, mode: str | None):
    """Load WORLD and apply ``--mode``; -> (world, kind, the world's own mode)."""
    from slam.registry import check_work, get_kind, load_world
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
        try:  # the mode changes the filter work
            check_work(w)
        except WorldError as exc:
            raise InputError(f"--mode {mode}: {exc}") from None
    return w, kind, world_mode


def _open_log(log_file: str, world: str | None, filters: str | None, runs: int | None,
              seed: int | None, workers: int | None, scheduler: str | None,
              mode: str | None, holdout: int | None = None, outages: tuple[str, ...] = ()):
    """``--log FILE``: the log as a one-run world (:func:`slam.logs.open_recorded`)."""
    from slam.logs import open_recorded

    for given, opt in ((world, "WORLD"), (runs, "--runs"), (seed, "--seed"),
                       (workers, "--workers"), (scheduler, "--scheduler")):
        if given is not None:
            raise InputError(f"{opt} does not apply to --log (a recorded log is one run)")
    return open_recorded(log_file, lambda kind: _parse_filters(filters, (), kind.filters),
                         mode, holdout, outages)


def _run_and_write(w, kind, campaign: dict[str, Any], workers: int, scheduler: str | None,
                   out: Path, plots: bool) -> None:
    """Prepare the output (before any work), run the campaign (local pool or Dask), write
    the report folder, print the table."""
    from slam.kinds.recorded.log import LogFormatError
    from slam.render.output import OutputError, abandon, prepare_output
    from slam.render.provenance import provenance
    from worlds import WorldError

    try:
        staging = prepare_output(out, campaign)
    except OutputError as exc:
        raise InputError(f"--out {exc}") from None
    draw_workers = workers  # the figures: as many processes as the campaign may use
    if scheduler is None:
        from slam.campaign import pool_size

        workers = pool_size(w, campaign["runs"], workers, campaign.get("executor", "batched"))
    try:
        result, elapsed = _campaign(w, campaign, workers, scheduler)
        result.summary["per_run"] = _per_run(w, result, campaign)
        result.summary["provenance"] = provenance(
            source=getattr(w, "source", None), seed=campaign["seed"], runs=campaign["runs"],
            workers=workers, scheduler=scheduler, wall_time_s=elapsed)
        _render(staging, result, kind.report, plots, draw_workers)
    except (WorldError, LogFormatError) as exc:  # found during the run: still bad input
        abandon(staging)
        raise InputError(str(exc) if isinstance(exc, WorldError) else f"--log {exc}") from None
    except BaseException:
        abandon(staging)
        raise
    click.echo(kind.report.text_table(result.summary))
    n, mode = campaign["runs"], campaign["mode"]
    executor = (f"dask scheduler {scheduler}" if scheduler else
                f"{workers} local worker{'s' if workers != 1 else ''}")
    in_mode = f" ({mode} mode)" if mode else ""
    click.echo(f"\n{n} run{'s' if n != 1 else ''} x {len(campaign['filters'])} filters + "
               f"baselines{in_mode} in {elapsed:.1f} s on {executor}; results in {out}/")
    if staging.previous is not None and staging.previous != campaign:
        click.echo(f"note: replaced the earlier results in {out}/ "
                   f"({describe_campaign(staging.previous)})")


def _per_run(w, result, campaign: dict[str, Any]) -> dict[str, Any]:
    """Every estimator's metrics on each run alone (:mod:`slam.per_run`)."""
    from slam.per_run import per_run

    return per_run(w, result.outcomes, campaign["filters"], campaign["seed"])


def _render(staging, result, report, plots: bool, workers: int) -> None:
    """Write the report folder (the figures by up to ``workers`` processes), with a
    progress bar over the figures."""
    from tqdm import tqdm

    from slam.render.output import commit

    with tqdm(desc="report: figures", unit="fig", file=sys.stderr, disable=None) as bar:
        def progress(name: str, i: int, n: int) -> None:
            bar.total = n
            bar.n = i
            bar.set_postfix_str(name)

        commit(staging, result, report, plots=plots, progress=progress, workers=workers)
        bar.n = bar.total or 0
        bar.refresh()


def describe_campaign(c: dict[str, Any]) -> str:
    """A recorded campaign in a few words (``{}``: unknown)."""
    if not c:
        return "an earlier campaign"
    mode = f", {c['mode']} mode" if c.get("mode") else ""
    return (f"world {c.get('world')}, {c.get('runs')} run(s), seed {c.get('seed')}{mode}, "
            f"filters {','.join(map(str, c.get('filters') or []))}")


def _campaign(w, campaign: dict[str, Any], workers: int, scheduler: str | None):
    """Run the campaign with a progress bar; -> (result, wall seconds)."""

    from slam.campaign import dask_mapper, run_campaign
    from slam.terminal import progress_bar

    mapper = client = None
    if scheduler:
        try:
            mapper, client = dask_mapper(scheduler)
        except (OSError, TimeoutError, ValueError, RuntimeError) as exc:
            raise InputError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
    t0 = time.perf_counter()
    try:
        with progress_bar(w, campaign, by_epochs=mapper is None) as (bar, runs_done, epochs):
            result = run_campaign(w, filters=campaign["filters"], runs=campaign["runs"],
                                  seed=campaign["seed"], workers=workers, mapper=mapper,
                                  executor=campaign.get("executor", "batched"),
                                  keep_all=campaign.get("tum") == "all",
                                  progress=runs_done, epochs=None if bar.disable else epochs)
    finally:
        if client is not None:
            client.close()
    return result, time.perf_counter() - t0


def _check_mode(kind, names: list[str], mode: str, where: str) -> None:
    allowed = (kind.mode_filters or {}).get(mode)
    if allowed is not None:
        bad = [n for n in names if n not in allowed]
        if bad:
            raise InputError(f"{where}: {', '.join(bad)} has no {mode} mode; {mode} mode "
                             f"supports {', '.join(allowed)} (or use --mode joint)")


if __name__ == "__main__":  # pragma: no cover
    main()
