"""TUM files that travel (:mod:`slam.render.tum`): an attitude-only kind's files say so and
carry zero position, the covariance sidecar matches the TUM rows, and ``--tum all`` writes
every run's files (``<name>.run<r>.tum``) with the same numbers as run 0's path."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

import slam.cli
from slam.testing import WORLDS


def _run(tmp_path, world: str, *extra: str):
    out = tmp_path / world
    res = CliRunner().invoke(slam.cli.main, ["run", str(WORLDS / f"{world}.toml"), "--runs",
                                             "2", "--workers", "1", "--no-plots", "--out",
                                             str(out), *extra])
    assert res.exit_code == 0, res.output
    return out, json.loads((out / "summary.json").read_text(encoding="utf-8"))


@pytest.mark.parametrize("world", ["tiny-star-sensor", "tiny-ship"])
def test_attitude_kinds_write_zero_position_tum_files_with_sidecars(tmp_path, world):
    out, _ = _run(tmp_path, world)
    head = (out / "srckf.tum").read_text(encoding="utf-8").splitlines()[:2]
    assert head[0].startswith(f"# {world}: srckf, run 0 of 2 (seed 0); attitude only: the "
                              "position columns are zero; q = q_nb")
    rows = np.loadtxt(out / "srckf.tum")
    assert head[1] == f"# {len(rows)} poses; t: seconds from the start of the run; columns " \
                      "t x y z qx qy qz qw"
    assert rows.shape[1] == 8 and np.all(rows[:, 1:4] == 0.0)
    np.testing.assert_allclose(np.linalg.norm(rows[:, 4:], axis=1), 1.0, atol=1e-8)
    cov = np.loadtxt(out / "srckf.cov.txt")
    assert cov.shape == (len(rows), 10)
    np.testing.assert_array_equal(cov[:, 0], rows[:, 0])
    c = cov[:, 1:].reshape(-1, 3, 3)
    np.testing.assert_allclose(c, np.swapaxes(c, 1, 2), rtol=1e-8)
    assert np.all(np.linalg.eigvalsh(c) > 0)
    assert (out / "truth.tum").exists() and not (out / "truth.cov.txt").exists()
    assert not (out / "srckf.run1.tum").exists()  # run 0 only by default


def test_tum_all_writes_every_run_with_the_same_numbers(tmp_path):
    one, s1 = _run(tmp_path / "a", "tiny-star-sensor")
    every, s2 = _run(tmp_path / "b", "tiny-star-sensor", "--tum", "all")
    for name in ("truth", "ekf", "srckf", "gtsam"):
        assert (every / f"{name}.run1.tum").exists()
        np.testing.assert_allclose(np.loadtxt(every / f"{name}.tum"),
                                   np.loadtxt(one / f"{name}.tum"), rtol=1e-7, atol=1e-9)
    assert "run 1 of 2" in (every / "srckf.run1.tum").read_text(encoding="utf-8")
    assert (every / "srckf.run1.cov.txt").exists()
    a, b = s1["filters"]["srckf"], s2["filters"]["srckf"]
    assert a["anees"] == pytest.approx(b["anees"], rel=1e-9)
    md = (every / "report.md").read_text(encoding="utf-8")
    assert "[`srckf.run1.tum`](srckf.run1.tum)" in md
