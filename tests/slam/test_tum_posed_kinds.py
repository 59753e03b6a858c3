"""TUM files of the fixed-wing, alignment and spinning kinds (:mod:`slam.render.tum`): read
back, each file's pose count and times are its estimator's epochs in the run, and its
quaternions (scalar last) and sidecar give back the run's own scored errors and σ, so a
wrong component order, time base or covariance block fails; ``--tum all`` writes every run.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import slam.cli
from estimators import wrap_angle
from nav.euler import euler_zyx_errors, q_to_euler_zyx
from nav.quaternion import qconj, qlog, qmul, qto_dcm
from slam.campaign import run_campaign
from slam.registry import load_world
from slam.results import REFERENCE
from slam.testing import WORLDS


def _read(path: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """``(comment lines, times, q_wxyz)`` of a TUM file, checking its declared pose count."""
    lines = path.read_text(encoding="utf-8").splitlines()
    head = [ln[2:] for ln in lines if ln.startswith("# ")]
    rows = np.loadtxt(path, ndmin=2)
    assert head[1].startswith(f"{len(rows)} poses; t: seconds from the start of the run")
    assert rows.shape[1] == 8
    return head, rows, np.column_stack([rows[:, 7], rows[:, 4:7]])


def _cov(path: Path, rows: np.ndarray, k: int) -> np.ndarray:
    c = np.loadtxt(path, ndmin=2)
    assert c.shape == (len(rows), 1 + k * k)
    np.testing.assert_array_equal(c[:, 0], rows[:, 0])
    return c[:, 1:].reshape(-1, k, k)


def _campaign(world, tmp_path: Path, write) -> tuple:
    result = run_campaign(world, runs=2, keep_all=True)
    files = write(result, tmp_path)
    assert "truth.run1.tum" in files
    return result, result.outcomes[0]


def test_fixed_wing_poses_and_ea_attitudes_match_the_run(tmp_path):
    from slam.kinds.fixed_wing.report import write_tum_files

    doc = (WORLDS / "tiny-fixed-wing.toml").read_text(encoding="utf-8")
    old = 'names = ["ins-ekf", "ins-srckf"]'
    assert old in doc
    path = tmp_path / "tiny-fw.toml"
    path.write_text(doc.replace(old, 'names = ["ea-ukf", "ins-srckf"]'), encoding="utf-8")
    _, o = _campaign(load_world(path), tmp_path, write_tum_files)
    _, truth, q_true = _read(tmp_path / "truth.tum")
    np.testing.assert_allclose(truth[:, 0], o.times, atol=1e-6)
    for name in ("ins-srckf", REFERENCE):
        head, rows, q = _read(tmp_path / f"{name}.tum")
        s = o.scores[name]
        assert "x, y: metres east/north of the start point" in head[0]
        np.testing.assert_allclose(rows[:, 0], s.times, atol=1e-6)
        np.testing.assert_allclose(rows[:, 1:4] - truth[:, 1:4], s.err_pos, atol=2e-5)
        cov = _cov(tmp_path / f"{name}.cov.txt", rows, 6)
        err, sig = euler_zyx_errors(q, cov[:, 3:6, 3:6], q_true)
        np.testing.assert_allclose(err, s.err_att, atol=1e-7)
        np.testing.assert_allclose(sig, s.sig_att, rtol=1e-6)
        np.testing.assert_allclose(np.sqrt(np.diagonal(cov[:, :3, :3], axis1=1, axis2=2)),
                                   s.sig_pos, rtol=1e-6)
    head, rows, q = _read(tmp_path / "ea-ukf.tum")
    s = o.scores["ea-ukf"]
    assert head[0].split("; ")[1].startswith("attitude only: the position columns are zero")
    assert np.all(rows[:, 1:4] == 0.0) and len(rows) > len(truth)  # 5 Hz against 1 Hz
    np.testing.assert_allclose(rows[:, 0], s.times, atol=1e-6)
    at = np.searchsorted(rows[:, 0], truth[:, 0])  # the INS epochs are EA epochs too
    np.testing.assert_allclose(rows[at, 0], truth[:, 0], atol=1e-6)
    np.testing.assert_allclose(wrap_angle(q_to_euler_zyx(q[at]) - q_to_euler_zyx(q_true)),
                               s.err_att[at], atol=1e-7)
    cov = _cov(tmp_path / "ea-ukf.cov.txt", rows, 3)
    np.testing.assert_allclose(np.sqrt(np.diagonal(cov, axis1=1, axis2=2)), s.sig_att,
                               rtol=1e-6)


def test_alignment_attitudes_give_the_scored_misalignment(tmp_path):
    from slam.kinds.alignment.report import write_tum_files

    world = load_world(WORLDS / "tiny-alignment.toml")
    _, o = _campaign(world, tmp_path, write_tum_files)
    _, truth, q_true = _read(tmp_path / "truth.tum")
    np.testing.assert_allclose(truth[:, 0], o.times, atol=1e-6)
    for name in [*world.filters.names, REFERENCE]:
        head, rows, q = _read(tmp_path / f"{name}.tum")
        assert "attitude only: the position columns are zero" in head[0]
        assert np.all(rows[:, 1:4] == 0.0)
        s = o.scores[name]
        at = np.flatnonzero(np.all(np.isfinite(s.err), axis=1))  # the smoother: its keys
        assert len(rows) == len(at) > 1
        np.testing.assert_allclose(rows[:, 0], o.times[at], atol=1e-6)
        err = qlog(qmul(q, qconj(q_true[at])))
        np.testing.assert_allclose(err, s.err[at], atol=1e-7)
        cov = _cov(tmp_path / f"{name}.cov.txt", rows, 3)
        sig = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
        np.testing.assert_allclose(sig, s.sigma[at], rtol=1e-6, equal_nan=True)


def _angles(q: np.ndarray) -> np.ndarray:
    """``[pitch, yaw, roll]`` of ``C_nb = Ry(yaw) Rz(pitch) Rx(roll)`` (North-Up-East)."""
    C = qto_dcm(q)
    return np.column_stack([np.arcsin(C[:, 1, 0]), np.arctan2(-C[:, 2, 0], C[:, 0, 0]),
                            np.arctan2(-C[:, 1, 2], C[:, 1, 1])])


def test_spinning_attitudes_give_the_scored_pitch_yaw_and_roll(tmp_path):
    from slam.kinds.spinning.report import write_tum_files
    from tests.slam.kinds.spinning.test_campaign import _tiny_file

    _, o = _campaign(load_world(_tiny_file(tmp_path)), tmp_path, write_tum_files)
    _, truth, q_true = _read(tmp_path / "truth.tum")
    np.testing.assert_allclose(truth[:, 0], o.times, atol=1e-6)
    true = _angles(q_true)
    np.testing.assert_allclose(true, wrap_angle(o.truth), atol=1e-7)
    for name in ("srckf", "srchinf", "ekf", REFERENCE):
        head, rows, q = _read(tmp_path / f"{name}.tum")
        assert "North-Up-East" in head[0] and np.all(rows[:, 1:4] == 0.0)
        np.testing.assert_allclose(rows[:, 0], o.times, atol=1e-6)
        s = o.scores[name]
        est = _angles(q)
        np.testing.assert_allclose(wrap_angle(est[:, :2] - true[:, :2]), s.err, atol=1e-7)
        np.testing.assert_allclose(wrap_angle(est[:, 2] - true[:, 2]), s.roll_err, atol=1e-6)
        cov = _cov(tmp_path / f"{name}.cov.txt", rows, 2)
        np.testing.assert_allclose(np.sqrt(np.diagonal(cov, axis1=1, axis2=2)), s.sigma,
                                   rtol=1e-6)


@pytest.mark.parametrize("world", ["tiny-fixed-wing", "tiny-alignment"])
def test_cli_writes_run_0_by_default_and_every_run_with_tum_all(tmp_path, world):
    for mode, runs in (("run0", ["truth.tum"]), ("all", ["truth.tum", "truth.run1.tum"])):
        out = tmp_path / mode
        res = CliRunner().invoke(slam.cli.main, ["run", str(WORLDS / f"{world}.toml"),
                                                 "--runs", "2", "--workers", "1",
                                                 "--no-plots", "--tum", mode, "--out",
                                                 str(out)])
        assert res.exit_code == 0, res.output
        assert {p.name for p in out.glob("truth*.tum")} == set(runs)
        md = (out / "report.md").read_text(encoding="utf-8")
        for stem in [f"srckf{r}" if world == "tiny-alignment" else f"ins-srckf{r}"
                     for r in ("", ".run1")[:len(runs)]]:
            assert f"[`{stem}.tum`]({stem}.tum)" in md
            assert f"[`{stem}.cov.txt`]({stem}.cov.txt)" in md
