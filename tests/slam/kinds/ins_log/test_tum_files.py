"""TUM files of the IMU + GNSS log kind (:mod:`slam.kinds.ins_log.report`): one pose per
fix epoch from the alignment fix, read back against the run's own scores (held-out error
and its normalised square from the sidecar's position block), the attitude against the
synthetic turn's true heading (a wrong quaternion order fails), and GTSAM's pose
covariance carried to the filters' ``[δp, δθ]`` (the smoothed one at the last fix equals
the EKF's there: a swapped block fails)."""

from __future__ import annotations

import json

import numpy as np
from click.testing import CliRunner

from slam import cli
from slam.kinds.ins_log.synthetic import write_log

NAMES = ("ekf", "srckf", "gtsam-online", "gtsam")


def _read(out, name):
    lines = (out / f"{name}.tum").read_text(encoding="utf-8").splitlines()
    head = [ln[2:] for ln in lines if ln.startswith("# ")]
    rows = np.loadtxt(out / f"{name}.tum", ndmin=2)
    assert head[1].startswith(f"{len(rows)} poses; t: seconds from the start of the run")
    c = np.loadtxt(out / f"{name}.cov.txt", ndmin=2)
    np.testing.assert_array_equal(c[:, 0], rows[:, 0])
    return head, rows, c[:, 1:].reshape(-1, 6, 6)


def test_every_estimator_writes_its_poses_and_pose_covariance(tmp_path):
    log = write_log(tmp_path, duration=75.0)
    out = tmp_path / "out"
    r = CliRunner().invoke(cli.main, ["run", "--log", str(log), "--holdout", "5", "--filters",
                                      "ekf,srckf", "--no-plots", "--out", str(out)])
    assert r.exit_code == 0, r.output
    s = json.loads((out / "summary.json").read_text())
    assert not list(out.glob("truth*.tum"))  # a log has no true attitude
    md = (out / "report.md").read_text(encoding="utf-8")
    files = {}
    for name in NAMES:
        assert f"[`{name}.tum`]({name}.tum)" in md
        head, rows, cov = _read(out, name)
        assert "ENU" in head[0] and "alignment fix" in head[0]
        files[name] = rows, cov
        t = rows[:, 0]
        np.testing.assert_allclose(t, np.arange(1.0, 75.0), atol=1e-6)  # fixes 1 .. 74
        e = s["filters" if name in ("ekf", "srckf") else "reference"][name]
        h = e["heldout"]
        idx = np.asarray(h["fix"]) - 1
        err = np.linalg.norm(rows[idx, 1:4] - _true_p(t[idx]), axis=1)
        np.testing.assert_allclose(err, h["error_m"], atol=2e-6)
        P = cov[idx, :3, :3] + 0.1**2 * np.eye(3)
        d = rows[idx, 1:4] - _true_p(t[idx])
        m = np.mean(np.einsum("ei,eij,ej->e", d, np.linalg.inv(P), d)) / 3
        np.testing.assert_allclose(m, h["mean_normalised_error"], rtol=1e-3, atol=1e-9)
        q = np.column_stack([rows[:, 7], rows[:, 4:7]])
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-8)
        yaw = 2 * np.arctan2(q[:, 3], q[:, 0])
        dyaw = np.angle(np.exp(1j * (yaw - 10.0 / 500.0 * t)))
        assert np.degrees(np.abs(dyaw)).max() < 1.0, name
        assert np.all(np.abs(q[:, 1:3]) < 0.02), name  # level: no roll or pitch
    on = files["gtsam-online"][1]
    fix = np.arange(1, 75)
    scored = (fix % 5 == 0) | (fix == 1)  # every withheld fix, and the prior's
    assert np.all(np.isfinite(on[scored])) and np.all(np.isnan(on[~scored]))
    sm, ekf = files["gtsam"][1][-1], files["ekf"][1][-1]
    assert np.all(np.isfinite(files["gtsam"][1]))
    np.testing.assert_allclose(np.sqrt(np.diag(sm)), np.sqrt(np.diag(ekf)), rtol=0.01)


def _true_p(t):
    from slam.kinds.ins_log.synthetic import turn

    return turn(t)[0]
