"""examples/kitti_ins.py: GTSAM's KITTI drive through the library (~3 s CPU)."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "kitti_ins.py"


def test_kitti_example_runs_and_follows_the_last_fix(capsys):
    code = [ln for ln in EXAMPLE.read_text().splitlines() if ln.strip()]
    assert len(code) <= 16  # the docstring and 15 lines
    env = runpy.run_path(str(EXAMPLE), run_name="__main__")
    out = capsys.readouterr().out
    assert "aligned at fix 1" in out
    log, belief = env["log"], env["belief"]
    assert np.linalg.norm(belief.mean[:3] - log.fix_p[-1]) < 1.0  # just updated with it
    assert np.isfinite(env["innovation"].nis)
