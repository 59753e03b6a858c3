r"""TUM trajectory files for every run that kept its tracks, with covariance sidecars.

``<name>.tum`` (run 0) and ``<name>.run<r>.tum`` (run r, with ``slam run --tum all``;
``truth`` where the run has a truth): one
line ``t x y z qx qy qz qw`` per pose, the time to the microsecond, after ``#`` comment
lines that name the world, the estimator, the run, the frames and the number of poses and
their time base.  Attitude-only kinds (and attitude-only estimators of a kind with
poses, e.g. the fixed-wing EA filters) write zero position (stated in the header); an
estimator's poses may be at its own epochs (:data:`TimesOf`).
``<name>[.run<r>].cov.txt`` beside it: per pose of the TUM file ``t`` then the pose
covariance row-major (its tangent and units in the header); rows of the TUM file and the
sidecar correspond one to one (poses without a finite estimate are left out of both).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from slam.render.output import tum_text, write_tum
from slam.results import Array, CampaignResult, PoseTrack, RunOutcome

TrackOf = Callable[[RunOutcome, str], tuple[Array, Array, Array | None]]
"""``(outcome, name) -> (positions (E, 3), quaternions q_wxyz (E, 4), covariance (E, k, k)
or None)`` of ``name`` (``"truth"``: the true trajectory) on that run."""
TimesOf = Callable[[RunOutcome, str], Array]
"""``(outcome, name) -> (E,)`` the times of ``name``'s poses (default: ``outcome.times``)."""
Note = str | Callable[[str], str]
"""A header note, the same for every file or per estimator name."""


def suffix(run: int) -> str:
    """The file-name part of a run: ``""`` for run 0, ``".run<r>"`` for the others."""
    return "" if run == 0 else f".run{run}"


def tracked(result: CampaignResult) -> list[RunOutcome]:
    """The runs that kept full tracks (run 0; every run with ``--tum all``)."""
    return [o for o in result.outcomes if o.tracks and o.times is not None]


def _names(o: RunOutcome, names: Iterable[str]) -> list[str]:
    """``truth`` (where the run has one: a recorded log may not) and the tracked ones."""
    return [*(["truth"] if o.truth is not None else []), *[n for n in names if n in o.tracks]]


def header(result: CampaignResult, run: int, name: str, note: str, poses: int) -> str:
    """The comment lines of a TUM file."""
    s = result.summary
    seed = f" (seed {s['seed']})" if "seed" in s else ""
    return (f"{s.get('world', '')}: {name}, run {run} of {s.get('runs', len(result.outcomes))}"
            f"{seed}; {note}\n"
            f"{poses} poses; t: seconds from the start of the run; "
            "columns t x y z qx qy qz qw")


def rows(times: Array, p: Array, q_wxyz: Array) -> tuple[Array, Array]:
    """TUM rows ``[t, x, y, z, qx, qy, qz, qw]`` of the finite poses, and their mask."""
    ok = (np.isfinite(times) & np.all(np.isfinite(p), axis=1)
          & np.all(np.isfinite(q_wxyz), axis=1))
    q = q_wxyz[ok]
    return np.column_stack([times[ok], p[ok], q[:, 1:], q[:, :1]]), ok


def cov_text(times: Array, cov: Array, head: str) -> str:
    """The sidecar: ``t`` and the row-major covariance per line (NaN where none)."""
    flat = cov.reshape(cov.shape[0], int(np.prod(cov.shape[1:])))  # 0 poses: 0 rows
    return "".join(f"# {line}\n" for line in head.splitlines()) + "".join(
        f"{t:.6f} " + " ".join(f"{v:.9g}" for v in c) + "\n" for t, c in zip(times, flat))


def write_cov(out_dir: Path, stem: str, times: Array, cov: Array, head: str) -> str:
    """Write :func:`cov_text` to ``<stem>.cov.txt`` in ``out_dir``; -> the file name."""
    name = f"{stem}.cov.txt"
    (out_dir / name).write_text(cov_text(times, cov, head), encoding="utf-8")
    return name


def _text(note: Note, name: str) -> str:
    return note if isinstance(note, str) else note(name)


def write_all(result: CampaignResult, out_dir: Path, names: Iterable[str], track: TrackOf,
              note: Note, cov_note: Note, times: TimesOf | None = None) -> list[str]:
    """Write every tracked run's ``truth`` and estimator TUM files and sidecars; -> the
    file names.  ``times`` gives each track's pose times where they are not the run's
    ``times`` (estimators at different epochs)."""
    texts: list[tuple[str, str]] = []
    sidecars: list[str] = []
    for o in tracked(result):
        for name in _names(o, names):
            p, q, cov = track(o, name)
            t = o.times if times is None else times(o, name)
            r, ok = rows(np.asarray(t, dtype=float), p, q)
            stem = f"{name}{suffix(o.run)}"
            texts.append((stem, tum_text(r, header(result, o.run, name, _text(note, name),
                                                   len(r)))))
            if cov is not None and name != "truth":
                sidecars.append(write_cov(
                    out_dir, stem, r[:, 0], cov[ok], f"{result.summary.get('world', '')}: "
                    f"{name}, run {o.run}: covariance per pose of {stem}.tum; "
                    f"{_text(cov_note, name)}"))
    return [*write_tum(out_dir, texts), *sidecars]


def links(result: CampaignResult, names: Iterable[str], what: Note,
          cov: bool = True) -> list[tuple[str, str]]:
    """The report's file list entries of :func:`write_all`'s files."""
    out = []
    for o in tracked(result):
        for name in _names(o, names):
            stem = f"{name}{suffix(o.run)}"
            who = "true" if name == "truth" else name
            out.append((f"{stem}.tum", f"run {o.run}'s {who} {_text(what, name)} (TUM)"))
            if cov and name != "truth":
                out.append((f"{stem}.cov.txt", f"its covariance per pose ({stem}.tum's rows)"))
    return out


ATTITUDE_NOTE = ("attitude only: the position columns are zero; q = q_nb (body to "
                 "navigation frame)")
ATTITUDE_COV = ("t, then the 3 x 3 attitude covariance row-major (rad², body-frame rotation "
                "vector: q = q̂ ⊗ Exp(δθ))")


def attitude_track(quats: Callable[[RunOutcome, str], Array],
                   covs: Callable[[RunOutcome, str], Array | None]) -> TrackOf:
    """A :data:`TrackOf` of an attitude-only kind: zero position, the 3 × 3 attitude block
    of the tangent covariance."""
    def of(o: RunOutcome, name: str) -> tuple[Array, Array, Array | None]:
        q = np.asarray(quats(o, name), dtype=float)
        c = covs(o, name)
        return np.zeros((len(q), 3)), q, None if c is None else np.asarray(c)[:, :3, :3]
    return of


def attitude_files(quats: Callable[[RunOutcome, str], Array],
                   covs: Callable[[RunOutcome, str], Array | None], poses: str
                   ) -> tuple[Callable[[CampaignResult, Path], list[str]],
                              Callable[[CampaignResult], list[tuple[str, str]]]]:
    """An attitude-only kind's ``(extra_files, links)`` for its report: TUM files with
    zero position (:func:`attitude_track`) and attitude covariance sidecars of every
    tracked run, ``poses`` saying which poses the files hold."""
    return report_files(attitude_track(quats, covs), f"{ATTITUDE_NOTE}; {poses}",
                        ATTITUDE_COV, "attitude (zero position)")


def report_files(track: TrackOf, note: Note, cov_note: Note, what: Note,
                 times: TimesOf | None = None
                 ) -> tuple[Callable[[CampaignResult, Path], list[str]],
                            Callable[[CampaignResult], list[tuple[str, str]]]]:
    """A kind's ``(extra_files, links)`` for its report: :func:`write_all` and
    :func:`links` over the estimators run 0 tracked, ``what`` naming each file's
    content in the report's list."""
    def write(result: CampaignResult, out_dir: Path) -> list[str]:
        return write_all(result, out_dir, list(result.outcomes[0].tracks), track, note,
                         cov_note, times)

    def link(result: CampaignResult) -> list[tuple[str, str]]:
        return links(result, list(result.outcomes[0].tracks), what)
    return write, link


def pose_track(truth: Callable[[RunOutcome], tuple[Array, Array]]) -> tuple[TrackOf, TimesOf]:
    """``(track, times)`` of a kind whose tracks are :class:`~slam.results.PoseTrack` values
    (zero position for one without), ``truth(outcome) -> (p, q_wxyz)`` at ``outcome.times``."""
    def of(o: RunOutcome, name: str) -> tuple[Array, Array, Array | None]:
        if name == "truth":
            p, q = truth(o)
            return p, q, None
        tr: PoseTrack = o.tracks[name]  # type: ignore[assignment]
        p = np.zeros((len(tr.q), 3)) if tr.p is None else tr.p
        return p, tr.q, tr.cov

    def times(o: RunOutcome, name: str) -> Array:
        return o.times if name == "truth" else o.tracks[name].times  # type: ignore[attr-defined,return-value]
    return of, times
