"""A user's arrays through the report (:func:`slam.arrays.report`): the constant-velocity
example end to end (files, a consistent SRCKF, ≤ 30 lines), and on synthetic Gaussian
errors the verdicts (consistent; optimistic with the covariance shrunk), a diverged run
counted with its epoch, per-run figures, and bad shapes refused naming the argument."""

from __future__ import annotations

import json
import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

from slam.arrays import report
from slam.scoring import anees_band

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "cv_target.py"


def test_the_cv_target_example_writes_the_report_of_a_consistent_filter(tmp_path, monkeypatch,
                                                                        capsys):
    assert len(EXAMPLE.read_text(encoding="utf-8").splitlines()) <= 30
    out = tmp_path / "cv"
    monkeypatch.setattr(sys, "argv", [str(EXAMPLE), str(out)])
    runpy.run_path(str(EXAMPLE), run_name="__main__")
    assert capsys.readouterr().out.startswith("consistent ")
    assert {"summary.json", "report.md", "report.html", "errors.png",
            "consistency.png"} <= {p.name for p in out.iterdir()}
    s = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    e = s["filters"]["srckf"]
    assert (s["kind"], s["runs"], e["runs_scored"], e["diverged_runs"]) == ("arrays", 20, 20, 0)
    assert e["anees_bounds_95"] == list(anees_band(20, 4))
    assert e["anees_bounds_95"][0] <= e["anees"] <= e["anees_bounds_95"][1]
    assert e["nis_bounds_95"][0] <= e["nis_per_dof"] <= e["nis_bounds_95"][1]
    assert e["nis_updates"] == 20 * 100
    assert len(e["per_run"]) == 20 and all("anees" in r for r in e["per_run"])
    assert 0.5 < e["rmse"]["x"] < 3.0 and e["rmse"]["vx"] < 1.0
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "| srckf |" in md and "consistent" in md and "![consistency.png]" in md


def _gaussian(rng, runs, E, P):
    return rng.multivariate_normal(np.zeros(len(P)), P, size=(runs, E))


def test_verdicts_divergence_and_per_run_figures_on_synthetic_errors(tmp_path):
    rng = np.random.default_rng(5)
    runs, E, P = 30, 40, np.diag([4.0, 0.25])
    cov = np.broadcast_to(P, (runs, E, 2, 2)).copy()
    good, bad = _gaussian(rng, runs, E, P), _gaussian(rng, runs, E, P)
    bad[3, 17:] = np.nan  # run 3 diverges at epoch 17
    nu = _gaussian(rng, runs, E, np.eye(1))
    nu[:, ::2] = np.nan  # an update every other epoch
    s = report(np.arange(E) * 0.5, {"good": good, "small-P": good, "broken": bad},
               {"good": cov, "small-P": cov / 10.0, "broken": cov}, truth=np.zeros((E, 2)),
               innovations={"good": nu, "small-P": 3 * nu, "broken": nu},
               innovation_covs={k: np.ones((runs, E, 1, 1)) for k in ("good", "small-P",
                                                                      "broken")},
               out=tmp_path / "r", name="synthetic", labels=("p", "v"), units=("m", "m/s"))
    f = s["filters"]
    assert f["good"]["consistency"] == "consistent", f["good"]
    assert f["small-P"]["consistency"] == "optimistic"
    assert f["small-P"]["anees"] == pytest.approx(10 * f["good"]["anees"], rel=1e-12)
    assert f["good"]["nis_consistency"] == "consistent"
    assert f["small-P"]["nis_consistency"] == "optimistic"
    assert f["good"]["nis_updates"] == runs * E // 2
    assert f["broken"]["diverged_runs"] == 1 and f["broken"]["runs_scored"] == runs - 1
    assert f["broken"]["failures"] == ["non-finite estimate or covariance at epoch 17 "
                                       "(t = 8.5)"]
    assert f["broken"]["per_run"][3] == {"run": 3, "diverged": True,
                                         "failure": f["broken"]["failures"][0]}
    # the RMSE is the hand computation over the runs and epochs
    assert f["good"]["rmse"]["p"] == pytest.approx(np.sqrt(np.mean(good[..., 0] ** 2)))
    assert (tmp_path / "r" / "errors.png").stat().st_size > 0


def test_bad_shapes_are_refused_naming_the_argument(tmp_path):
    t, est = np.arange(5.0), np.zeros((5, 2))
    with pytest.raises(ValueError, match=r"covariances\['filter'\]: shape \(5, 2\)"):
        report(t, est, np.zeros((5, 2)), out=tmp_path / "a", plots=False)
    with pytest.raises(ValueError, match=r"truth: shape \(4, 2\)"):
        report(t, est, truth=np.zeros((4, 2)), out=tmp_path / "b", plots=False)
    with pytest.raises(ValueError, match="times"):
        report(np.zeros((5, 1)), est, out=tmp_path / "c", plots=False)
    with pytest.raises(ValueError, match="labels / units"):
        report(t, est, labels=("a",), out=tmp_path / "d", plots=False)
    assert not any(tmp_path.iterdir())
