"""Writing a campaign's report folder atomically, and only where it is safe.

:func:`write_outputs` renders a :class:`~slam.results.CampaignResult` into a fresh
temporary folder next to the output folder and only then swaps it into place, so a
failed or interrupted run leaves either the old folder or the new one, never a mix:
``summary.json`` (strict JSON), ``report.md``, ``report.html`` (figures embedded), the
kind's figures, its extra files (e.g. trajectories) and the marker :data:`MARKER`.

Safety (:func:`prepare_output`, called by the command line before a campaign starts):

* the target is used only if it is absent, an empty folder, or a previous output of
  this tool (it holds :data:`MARKER`, and no file beyond those the marker lists as
  written); anything else raises :class:`OutputError` and nothing is touched;
* a symbolic link is followed to its folder (a dangling one is refused), and a target
  that is or contains the current folder is refused;
* the temporary folder is created at once, so an unwritable place fails before the
  campaign, not after it; its name carries the process id, and temporary (or
  swapped-out) folders of earlier runs that were killed are removed (only those that
  hold the marker: nothing this tool did not write is ever deleted).
"""

from __future__ import annotations

import contextlib
import errno
import glob
import json
import os
import shutil
import stat
import tempfile
import uuid
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from slam.render.document import KindReport, report_html, report_markdown
from slam.render.figure_pool import draw_figures
from slam.render.tables import summary_json
from slam.results import CampaignResult

SUMMARY = "summary.json"
MARKER = ".slam-output"
"""The file that marks a folder as written by this tool (JSON: the campaign)."""


class OutputError(Exception):
    """An output folder that cannot (or must not) be written; ``str`` names the folder
    and the reason.  Nothing has been changed when it is raised."""


def render(result: CampaignResult, kr: KindReport, out_dir: Path, *, plots: bool = True,
           progress: Callable[[str, int, int], None] | None = None,
           workers: int = 1) -> list[str]:
    """Write every output file into the existing folder ``out_dir`` (not atomic); the
    figures drawn by up to ``workers`` processes (:mod:`slam.render.figure_pool`),
    ``progress(name, i, n)`` as they go."""
    (out_dir / SUMMARY).write_text(summary_json(result.summary), encoding="utf-8")
    figures: dict[str, bytes] = {}
    if plots:
        specs = kr.figures()
        figures = draw_figures(result, {name: plot for name, (plot, _) in specs.items()},
                               out_dir, workers, progress)
    (out_dir / "report.md").write_text(report_markdown(result, kr, list(figures)),
                                       encoding="utf-8")
    (out_dir / "report.html").write_text(report_html(result, kr, figures), encoding="utf-8")
    extra = kr.extra_files(result, out_dir)
    return [SUMMARY, "report.md", "report.html", *figures, *extra]


def tum_text(rows: np.ndarray, header: str = "") -> str:
    """TUM trajectory lines from rows ``[t, x, y, z, qx, qy, qz, qw]``: the time to the
    microsecond, the rest to 9 significant digits; after ``header`` as ``#`` comment
    lines."""
    return "".join(f"# {line}\n" for line in header.splitlines()) + "".join(
        " ".join(f"{v:.9g}" if j else f"{v:.6f}" for j, v in enumerate(r)) + "\n"
        for r in rows)


def tum_names(result: CampaignResult) -> list[str]:
    """The run-0 trajectories a kind writes as TUM files: ``truth`` and every estimator run 0
    tracked (none where run 0 kept no truth)."""
    first = result.outcomes[0]
    if first.truth is None or first.times is None:
        return []
    return ["truth", *first.tracks]


def tum_header(result: CampaignResult, name: str, frame: str = "") -> str:
    """The comment line heading run 0's TUM file of ``name``: world, run, seed, the
    ``frame`` note (e.g. ``"ENU, q_nb; "``) and the columns."""
    s = result.summary
    return (f"{s.get('world', '')}: {name}, run 0 of {s.get('runs', len(result.outcomes))} "
            f"(seed {s.get('seed', '?')}); {frame}columns t x y z qx qy qz qw")


def write_tum(out_dir: Path, trajectories: Iterable[tuple[str, str]]) -> list[str]:
    """Write each ``(name, TUM text)`` to ``<name>.tum`` in ``out_dir``; the file names."""
    written = []
    for name, text in trajectories:
        (out_dir / f"{name}.tum").write_text(text, encoding="utf-8")
        written.append(f"{name}.tum")
    return written


# --------------------------------------------------------------------------- the target

@dataclass
class Staging:
    """A prepared output: the final folder, the temporary folder being filled, the parent
    folders this run created (removed again if it fails) and the campaign recorded in
    the folder it will replace (``None``: nothing to replace; ``{}``: unknown)."""

    out_dir: Path
    tmp: Path
    created: list[Path] = field(default_factory=list)
    previous: dict[str, Any] | None = None
    campaign: dict[str, Any] | None = None


def _marked(folder: Path) -> bool:
    return (folder / MARKER).is_file()


def read_marker(folder: Path) -> tuple[dict[str, Any], list[str] | None]:
    """The campaign recorded in ``folder``'s marker (``{}`` when unreadable) and the files
    it lists as written (``None`` when it lists none)."""
    try:
        data = json.loads((folder / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # not a marker slam wrote
        data = {}
    data = data if isinstance(data, dict) else {}
    campaign, files = data.get("campaign"), data.get("files")
    return (campaign if isinstance(campaign, dict) else {},
            [str(f) for f in files] if isinstance(files, list) else None)


def _write_marker(folder: Path, campaign: dict[str, Any] | None,
                  files: list[str] | None = None) -> None:
    data = {"written_by": "slam (navfilters)", "campaign": campaign or {}, "files": files}
    text = json.dumps(data, indent=1, default=str)
    (folder / MARKER).write_text(text + "\n", encoding="utf-8")


def _loops(path: Path) -> bool:
    """``path`` (or a link on the way to it) is a symbolic link loop (``ELOOP``)."""
    try:
        os.stat(path)
    except OSError as exc:
        return exc.errno == errno.ELOOP
    except ValueError:  # a NUL character
        return False
    return False


def _resolve(out_dir: Path) -> Path:
    """The absolute folder to write: a symbolic link is followed (a dangling one or a loop
    refused)."""
    path = Path(os.path.abspath(out_dir))
    if _loops(path):
        raise OutputError(f"{out_dir}: is or passes through a symbolic link loop (ELOOP: the "
                          "links never reach a file or folder)")
    if path.is_symlink():
        target = Path(os.path.realpath(path))
        if not target.exists():
            raise OutputError(f"{out_dir}: is a symbolic link to {target}, which does not "
                              "exist")
        path = target
    return path


def _check_target(path: Path, shown: Path) -> dict[str, Any] | None:
    """Refuse a target this tool must not replace; -> the campaign it holds (or None)."""
    if path.exists() and not path.is_dir():
        raise OutputError(f"{shown}: exists and is not a folder")
    cwd = Path(os.getcwd()).resolve()
    if path.exists() and (cwd == path.resolve() or path.resolve() in cwd.parents):
        raise OutputError(f"{shown}: is (or contains) the current folder; choose a "
                          "sub-folder")
    if not path.exists():
        return None
    try:
        names = [p.name for p in path.iterdir()]
    except OSError as exc:
        raise OutputError(f"{shown}: cannot read the folder ({exc.strerror or exc})") from None
    if not names:
        return None
    if MARKER not in names:
        raise OutputError(f"{shown}: is not empty and is not an earlier output of slam (no "
                          f"{MARKER} file in it); nothing was changed - choose another "
                          "--out or empty the folder")
    campaign, files = read_marker(path)
    foreign = sorted(set(names) - {MARKER, *(files if files is not None else names)})
    if foreign:
        raise OutputError(f"{shown}: holds {len(foreign)} file(s) slam did not write "
                          f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''});"
                          " nothing was changed - move them or choose another --out")
    if not os.access(path, os.W_OK | os.X_OK):
        raise OutputError(f"{shown}: is not writable")
    return campaign


def _make_parents(parent: Path, shown: Path) -> list[Path]:
    """Create ``parent`` (and its missing ancestors); -> the folders created, deepest last."""
    missing = [p for p in (parent, *parent.parents) if not p.exists()][::-1]
    for p in missing:
        try:
            p.mkdir()
        except FileExistsError:
            if _loops(p):
                raise OutputError(f"{shown}: {p} is a symbolic link loop (ELOOP: the links "
                                  "never reach a folder)") from None
            if not p.is_dir():
                raise OutputError(f"{shown}: {p} exists and is not a folder") from None
        except OSError as exc:
            raise OutputError(f"{shown}: cannot create {p} ({exc.strerror or exc})") from None
    return missing


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True
    return True


def clean_stale(out_dir: Path) -> list[Path]:
    """Remove the temporary and swapped-out folders of ``out_dir`` left by runs that were
    killed (their process is gone) and that hold the marker; a swapped-out folder whose
    target is missing is put back.  Returns the folders removed or restored."""
    done = []
    for kind in ("tmp", "old"):
        pattern = f".{glob.escape(out_dir.name)}.{kind}-*-*"
        for p in sorted(out_dir.parent.glob(pattern)):
            pid = p.name[len(out_dir.name) + len(kind) + 3:].split("-", 1)[0]
            if not pid.isdigit() or _pid_alive(int(pid)) or not p.is_dir() or not _marked(p):
                continue
            with contextlib.suppress(OSError):
                if kind == "old" and not out_dir.exists():
                    os.rename(p, out_dir)
                else:
                    shutil.rmtree(p)
                done.append(p)
    return done


def prepare_output(out_dir: Path, campaign: dict[str, Any] | None = None) -> Staging:
    """Check ``out_dir`` and create its temporary folder (module docstring); raises
    :class:`OutputError` (nothing changed) when it cannot or must not be written."""
    path = _resolve(out_dir)
    previous = _check_target(path, out_dir)
    created = _make_parents(path.parent, out_dir)
    try:
        clean_stale(path)
        tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.tmp-{os.getpid()}-"))
    except OSError as exc:
        _remove_created(created)
        raise OutputError(f"{out_dir}: cannot write in {path.parent} "
                          f"({exc.strerror or exc})") from None
    staging = Staging(path, tmp, created, previous, campaign)
    try:
        _write_marker(tmp, campaign)
    except BaseException:
        abandon(staging)
        raise
    return staging


def _remove_created(created: list[Path]) -> None:
    for p in reversed(created):
        with contextlib.suppress(OSError):
            p.rmdir()  # only if still empty


def abandon(staging: Staging) -> None:
    """Remove the temporary folder and the parent folders this run created (if empty)."""
    shutil.rmtree(staging.tmp, ignore_errors=True)
    _remove_created(staging.created)


def _default_dir_mode() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o777 & ~mask


def _swap_into_place(new: Path, out_dir: Path) -> None:
    """Move the finished folder ``new`` to ``out_dir``, replacing (then deleting) the
    old one; if the final rename fails the old folder is put back."""
    if out_dir.exists():
        new.chmod(stat.S_IMODE(out_dir.stat().st_mode))
        old = out_dir.with_name(f".{out_dir.name}.old-{os.getpid()}-{uuid.uuid4().hex[:12]}")
        os.rename(out_dir, old)
        try:
            os.rename(new, out_dir)
        except BaseException:
            os.rename(old, out_dir)
            raise
        shutil.rmtree(old, ignore_errors=True)
    else:
        new.chmod(_default_dir_mode())
        os.rename(new, out_dir)


def commit(staging: Staging, result: CampaignResult, kr: KindReport, *, plots: bool = True,
           progress: Callable[[str, int, int], None] | None = None,
           workers: int = 1) -> list[Path]:
    """Render into the staging folder (``progress`` and ``workers`` as in :func:`render`)
    and swap it into place; on any error the staging folder is removed (:func:`abandon`)
    and an existing output is left as it was."""
    try:
        names = render(result, kr, staging.tmp, plots=plots, progress=progress,
                       workers=workers)
        _write_marker(staging.tmp, staging.campaign, names)
        _swap_into_place(staging.tmp, staging.out_dir)
    except BaseException:
        abandon(staging)
        raise
    return [staging.out_dir / n for n in [*names, MARKER]]


def write_outputs(result: CampaignResult, kr: KindReport, out_dir: Path, *, plots: bool = True,
                  campaign: dict[str, Any] | None = None) -> list[Path]:
    """Write the campaign's report folder atomically and return the files written.

    :func:`prepare_output` then :func:`commit`: ``out_dir`` must be absent, empty or an
    earlier output (else :class:`OutputError`); everything is rendered into a temporary
    folder next to it which then replaces it in one rename; on any error the temporary
    folder is removed and an existing ``out_dir`` is left as it was.
    """
    return commit(prepare_output(Path(out_dir), campaign), result, kr, plots=plots)
