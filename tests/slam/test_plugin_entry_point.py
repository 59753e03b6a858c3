"""An external plug-in kind (examples/plugin_kind: the ``cvtrack1d`` package) pip-installed
into a fresh test venv is found through the ``navfilters.kinds`` / ``navfilters.worlds``
entry points: ``slam worlds`` lists its world and ``slam run`` runs it end to end (the
venv sees this checkout's packages through a ``.pth`` file; nothing is downloaded)."""

from __future__ import annotations

import json
import shutil
import site
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PLUGIN = ROOT / "examples" / "plugin_kind"


@pytest.fixture(scope="module")
def plugin_venv(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("plugin")
    env_dir = tmp / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    py = env_dir / "bin" / "python"
    purelib = subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_paths()"
                              "['purelib'])"], capture_output=True, text=True,
                             check=True).stdout.strip()
    # this checkout's environment (numpy, gtsam, the project itself) under the new venv
    (Path(purelib) / "navfilters-checkout.pth").write_text(
        "\n".join([*site.getsitepackages(), str(ROOT)]) + "\n", encoding="utf-8")
    src = tmp / "src"
    shutil.copytree(PLUGIN, src)  # builds write next to the sources: not in the checkout
    res = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q",
                          "--no-deps", "--no-build-isolation", "--no-index", str(src)],
                         capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr
    return py


def _slam(py: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(py), "-m", "slam.cli", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def test_slam_worlds_lists_the_plugins_world(plugin_venv, tmp_path):
    res = _slam(plugin_venv, "worlds", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    line = next(ln for ln in res.stdout.splitlines() if ln.startswith("line "))
    assert "cv-tracker-1d" in line and "Plug-in kind: a target on a line" in line
    assert any(ln.startswith("bailey ") for ln in res.stdout.splitlines())


def test_slam_run_runs_the_plugins_world(plugin_venv, tmp_path):
    res = _slam(plugin_venv, "run", "line", "--workers", "1", "--out", "out", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "srckf" in res.stdout
    s = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert (s["kind"], s["runs"]) == ("cv-tracker-1d", 20)
    for name in ("ekf", "srckf"):
        e = s["filters"][name]
        lo, hi = e["anees_bounds_95"]
        assert lo <= e["anees"] <= hi, e  # the exact Kalman filter is consistent
    assert "## Results" in (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    # a bad world of the plug-in kind: one line naming the file and the key, exit 2
    bad = tmp_path / "bad.toml"
    bad.write_text((PLUGIN / "cvtrack1d" / "worlds" / "line.toml").read_text(encoding="utf-8")
                   .replace("sigma_pos_m = 1.0", "sigma_pos_m = -1.0"), encoding="utf-8")
    res = _slam(plugin_venv, "run", str(bad), "--out", "out2", cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert "[sensor] sigma_pos_m = -1.0: must be in (0, 1000]" in res.stderr


def test_a_broken_plugin_is_skipped_with_one_warning_line(monkeypatch, capsys):
    import importlib.metadata as md

    from slam import registry

    eps = [md.EntryPoint("gone", "no_such_module_here:KIND", registry.PLUGIN_KINDS),
           md.EntryPoint("notkind", "math:pi", registry.PLUGIN_KINDS)]
    monkeypatch.setattr(md, "entry_points", lambda group: eps if group ==
                        registry.PLUGIN_KINDS else [])
    before = dict(registry.KINDS)
    assert registry.load_plugins() == []
    err = capsys.readouterr().err.splitlines()
    assert err == ["warning: plug-in kind gone (no_such_module_here:KIND) not loaded: "
                   "ModuleNotFoundError: No module named 'no_such_module_here'",
                   "warning: plug-in kind notkind (math:pi) not loaded: TypeError: math:pi is "
                   "a float, not a slam.kind.Kind"]
    assert registry.KINDS == before
