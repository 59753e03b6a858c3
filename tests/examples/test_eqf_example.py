"""examples/eqf_attitude.py on the first 20 s of GTSAM's EqFdata.csv (~2 s CPU for both).

Measured on the first 20 s (t >= 10 s RMS / error at t = 20 s): SRCKF 1.234° / 1.444°,
MEKF 1.234° / 1.445°; the two filters' errors differ by at most 0.008° after 10 s.
The whole set (printed by the example): SRCKF 0.817° / 3.579° at t = 60 s, MEKF
0.818° / 3.577°.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "eqf_attitude.py"
SECONDS = 20.0


def load_example() -> ModuleType:
    # by path: ``examples`` is not an installed package (``python -m`` runs it from the root)
    spec = importlib.util.spec_from_file_location("eqf_attitude_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def results() -> dict[str, dict]:
    example = load_example()
    return {name: example.run(name, max_seconds=SECONDS) for name in ("srckf", "ekf")}


@pytest.mark.parametrize("name", ["srckf", "ekf"])
def test_figures(results: dict[str, dict], name: str) -> None:
    r = results[name]
    assert r["final_t_s"] == SECONDS
    assert np.all(np.isfinite(r["errors_deg"])) and r["errors_deg"].shape == r["t_s"].shape
    assert len(r["t_s"]) == 1539  # rows with a direction reading in 20 s, plus the last row
    assert r["rms_after_10s_deg"] < 1.6  # measured 1.234
    assert r["final_deg"] < 2.0  # measured 1.444 / 1.445
    assert np.max(r["errors_deg"][r["t_s"] >= 10.0]) < 3.0  # measured 1.96


def test_srckf_and_mekf_agree(results: dict[str, dict]) -> None:
    a, b = results["srckf"], results["ekf"]
    late = a["t_s"] >= 10.0
    assert np.max(np.abs(a["errors_deg"] - b["errors_deg"])[late]) < 0.05  # measured 0.008
    assert abs(a["rms_after_10s_deg"] - b["rms_after_10s_deg"]) < 0.02  # measured 0.0003
