"""The report's figures drawn by worker processes equal the ones drawn in turn."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from slam.render.figure_pool import can_fork, draw_figures


def _writer(text: str):
    def plot(result: dict, path: Path) -> None:
        path.write_text(f"{text} {result['value']} pid-independent", encoding="utf-8")
    return plot


def _boom(result: dict, path: Path) -> None:
    raise ValueError("figure failed on purpose")


def _pid(result: dict, path: Path) -> None:
    path.write_text(str(os.getpid()), encoding="utf-8")


PLOTS = {f"f{i}.txt": _writer(f"figure {i}") for i in range(5)}


@pytest.mark.skipif(not can_fork(), reason="worker figures need fork")
def test_figures_from_two_workers_equal_those_drawn_in_turn(tmp_path: Path):
    one, two = tmp_path / "one", tmp_path / "two"
    one.mkdir()
    two.mkdir()
    seen: list[tuple[str, int, int]] = []
    a = draw_figures({"value": 7}, PLOTS, one, workers=1)
    b = draw_figures({"value": 7}, PLOTS, two, workers=2,
                     progress=lambda name, i, n: seen.append((name, i, n)))
    assert list(a) == list(b) == list(PLOTS)  # the kinds' order, whoever finished first
    assert a == b and a["f3.txt"] == b"figure 3 7 pid-independent"
    assert sorted(s[0] for s in seen) == sorted(PLOTS) and {s[2] for s in seen} == {5}
    assert [s[1] for s in seen] == [1, 2, 3, 4, 5]


@pytest.mark.skipif(not can_fork(), reason="worker figures need fork")
def test_figures_are_drawn_in_other_processes_and_a_failure_is_raised(tmp_path: Path):
    out = draw_figures({}, {"a.txt": _pid, "b.txt": _pid}, tmp_path, workers=2)
    assert str(os.getpid()).encode() not in out.values()
    with pytest.raises(ValueError, match="on purpose"):
        draw_figures({"value": 1}, {"ok.txt": _writer("x"), "bad.txt": _boom}, tmp_path,
                     workers=2)
