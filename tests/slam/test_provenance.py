"""The provenance block (:mod:`slam.render.provenance`): what it records, that every item is
best effort, and how the reports show it."""

from __future__ import annotations

import datetime as dt
import hashlib
from importlib import metadata
from importlib.resources import files

from slam.render import provenance as prov


def test_block_records_code_input_command_time_and_executor(tmp_path):
    world = tmp_path / "w.toml"
    world.write_bytes(b"kind = 'planar-slam'\n")
    started = dt.datetime(2026, 1, 2, 3, 4, 5, tzinfo=dt.UTC)
    block = prov.provenance(argv=["/usr/bin/slam", "run", str(world), "--runs", "5"],
                            source=str(world), seed=7, runs=5, workers=2, started=started,
                            wall_time_s=12.34567)
    assert block["version"] == metadata.version("navfilters")
    assert block["command"] == f"slam run {world} --runs 5"
    assert block["world_sha256"] == hashlib.sha256(world.read_bytes()).hexdigest()
    assert (block["seed"], block["runs"], block["workers"], block["scheduler"]) == (7, 5, 2, None)
    assert block["started_utc"] == "2026-01-02T03:04:05+00:00"
    assert block["wall_time_s"] == 12.346
    assert set(block["libraries"]) == set(prov.LIBRARIES)
    dask = prov.provenance(argv=["slam"], workers=2, scheduler="tcp://h:8786")
    assert dask["workers"] is None and dask["scheduler"] == "tcp://h:8786"
    # without a start time the start is now minus the wall time
    hour = prov.provenance(argv=["slam"], wall_time_s=3600.0)["started_utc"]
    ago = dt.datetime.now(dt.UTC) - dt.datetime.fromisoformat(hour)
    assert dt.timedelta(minutes=59) < ago < dt.timedelta(minutes=61)


def test_bundled_world_is_hashed_from_the_package_and_missing_files_give_none():
    bundled = (files("worlds") / "bailey.toml").read_bytes()
    assert prov.file_sha256("worlds/bailey.toml") == hashlib.sha256(bundled).hexdigest()
    assert prov.file_sha256("no/such/file.toml") is None
    assert prov.file_sha256(None) is None


def test_outside_a_git_work_tree_the_commit_is_none(tmp_path, monkeypatch):
    monkeypatch.setattr(prov, "_ROOT", tmp_path)
    assert prov.git_commit() == (None, None)
    assert prov.provenance(argv=["slam"])["git_commit"] is None
    monkeypatch.setattr(prov.metadata, "version", _not_installed)
    assert prov.package_version() is None
    assert "(not installed)" in prov.version_text()


def _not_installed(name):
    raise metadata.PackageNotFoundError(name)


def test_version_text_and_rendering():
    text = prov.version_text()
    assert text.startswith(f"navfilters {metadata.version('navfilters')}")
    assert "numpy" in text and "Python" in text
    block = prov.provenance(argv=["slam", "run"], workers=1, wall_time_s=3.0)
    rows = dict(map(tuple, prov.provenance_rows(block)))
    assert rows["command line"] == "slam run" and rows["local workers"] == "1"
    assert "Dask scheduler" not in rows and "world / log file" not in rows  # None left out
    line = prov.provenance_line(block)
    assert line.startswith("Provenance: navfilters") and "3.0 s wall, 1 local worker " in line
    assert prov.provenance_rows(None) == [] and prov.provenance_line("x") == ""
