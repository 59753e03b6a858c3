"""``--out`` through a symbolic link loop (:mod:`slam.render.output`): refused before any
run with a message that says it is a loop (ELOOP) - before (issue 24) it said the
target "does not exist" - and the links are left as they were; a marker that is not
one slam wrote (nested past the recursion limit) reads as no campaign."""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner

from slam import cli
from slam.render.output import MARKER, OutputError, prepare_output, read_marker

LOOP = "is or passes through a symbolic link loop (ELOOP: the links never reach a file or folder)"


def test_a_symlink_loop_as_out_is_named_a_loop(tmp_path, monkeypatch):
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    (tmp_path / "self").symlink_to(tmp_path / "self")
    for out in (tmp_path / "a", tmp_path / "self", tmp_path / "self" / "sub"):
        with pytest.raises(OutputError) as err:
            prepare_output(out)
        assert str(err.value) == f"{out}: {LOOP}"
    monkeypatch.setattr("slam.campaign.run_campaign", lambda *a, **k: pytest.fail("ran"))
    res = CliRunner().invoke(cli.main, ["run", "bailey", "--runs", "1", "--out",
                                        str(tmp_path / "a")])
    assert res.exit_code == 2 and res.output == f"error: --out {tmp_path / 'a'}: {LOOP}\n"
    assert sorted(os.listdir(tmp_path)) == ["a", "b", "self"]
    assert all((tmp_path / n).is_symlink() for n in ("a", "b", "self"))


def test_a_marker_nested_past_the_recursion_limit_is_no_campaign(tmp_path):
    (tmp_path / MARKER).write_text("[" * 100_000 + "]" * 100_000)
    assert read_marker(tmp_path) == ({}, None)
