"""Writing a campaign's report folder atomically.

:func:`write_outputs` renders a :class:`~slam.results.CampaignResult` into a fresh
temporary folder next to the output folder and only then swaps it into place, so a
failed or interrupted run leaves either the old folder or the new one, never a mix:
``summary.json`` (strict JSON), ``report.md``, ``report.html`` (figures embedded), the
kind's figures and its extra files (e.g. trajectories).
"""

from __future__ import annotations

import os
import shutil
import stat
import tempfile
import uuid
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from slam.render.document import KindReport, report_html, report_markdown
from slam.render.tables import summary_json
from slam.results import CampaignResult

SUMMARY = "summary.json"


def render(result: CampaignResult, kr: KindReport, out_dir: Path, *, plots: bool = True
           ) -> list[str]:
    """Write every output file into the existing folder ``out_dir`` (not atomic)."""
    (out_dir / SUMMARY).write_text(summary_json(result.summary), encoding="utf-8")
    figures: dict[str, bytes] = {}
    if plots:
        for name, (plot, _) in kr.figures().items():
            plot(result, out_dir / name)
            figures[name] = (out_dir / name).read_bytes()
    (out_dir / "report.md").write_text(report_markdown(result, kr, list(figures)),
                                       encoding="utf-8")
    (out_dir / "report.html").write_text(report_html(result, kr, figures), encoding="utf-8")
    extra = kr.extra_files(result, out_dir)
    return [SUMMARY, "report.md", "report.html", *figures, *extra]


def tum_text(rows: np.ndarray) -> str:
    """TUM trajectory lines from rows ``[t, x, y, z, qx, qy, qz, qw]``: the time to the
    microsecond, the rest to 9 significant digits."""
    return "".join(" ".join(f"{v:.9g}" if j else f"{v:.6f}" for j, v in enumerate(r)) + "\n"
                   for r in rows)


def write_tum(out_dir: Path, trajectories: Iterable[tuple[str, str]]) -> list[str]:
    """Write each ``(name, TUM text)`` to ``<name>.tum`` in ``out_dir``; the file names."""
    written = []
    for name, text in trajectories:
        (out_dir / f"{name}.tum").write_text(text, encoding="utf-8")
        written.append(f"{name}.tum")
    return written


def _default_dir_mode() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o777 & ~mask


def _swap_into_place(new: Path, out_dir: Path) -> None:
    """Move the finished folder ``new`` to ``out_dir``, replacing (then deleting) the
    old one; if the final rename fails the old folder is put back."""
    if out_dir.exists():
        new.chmod(stat.S_IMODE(out_dir.stat().st_mode))
        old = out_dir.with_name(f".{out_dir.name}.old-{uuid.uuid4().hex[:12]}")
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


def write_outputs(result: CampaignResult, kr: KindReport, out_dir: Path, *, plots: bool = True
                  ) -> list[Path]:
    """Write the campaign's report folder atomically and return the files written.

    Everything is rendered into a temporary folder next to ``out_dir`` which then
    replaces ``out_dir`` in one rename; on any error the temporary folder is removed and
    an existing ``out_dir`` is left as it was.
    """
    out_dir = Path(out_dir).absolute()
    if out_dir.exists() and not out_dir.is_dir():
        raise NotADirectoryError(f"{out_dir} exists and is not a directory")
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=out_dir.parent, prefix=f".{out_dir.name}.tmp-"))
    try:
        names = render(result, kr, tmp, plots=plots)
        _swap_into_place(tmp, out_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return [out_dir / n for n in names]
