"""``summary.json``'s per-run figures (:mod:`slam.per_run`): written by ``slam run``, one row
per run and estimator, and the campaign's RMSE re-derived from them (runs of equal length:
the RMS of the runs' RMSEs), strict JSON without unexplained nulls."""

from __future__ import annotations

import json
import math

from click.testing import CliRunner

import slam.cli
from slam.nulls import unexplained_nulls
from slam.testing import WORLDS


def test_per_run_figures_re_derive_the_campaign_table(tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(slam.cli.main, ["run", str(WORLDS / "tiny-planar.toml"),
                                             "--runs", "3", "--workers", "1", "--no-plots",
                                             "--out", str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert unexplained_nulls(s) == []
    per = s["per_run"]
    assert set(per) == {"ekf", "srckf", "gtsam", "odometry"}
    for name in ("ekf", "srckf"):
        rows = per[name]
        assert [r["run"] for r in rows] == [0, 1, 2] and not any(r["diverged"] for r in rows)
        rms = math.sqrt(sum(r["pos_rmse_m"] ** 2 for r in rows) / 3)
        assert math.isclose(rms, s["filters"][name]["pos_rmse_m"], rel_tol=1e-9)
        assert len({r["pos_rmse_m"] for r in rows}) == 3  # the runs differ
