"""The kind registry (:mod:`slam.registry`): the built-in kinds, listing the bundled worlds,
dispatching a world document to its kind."""

from __future__ import annotations

import subprocess
import sys

import pytest

from slam.kind import Kind
from slam.registry import KINDS, get_kind, list_worlds, load_world, log_kind, world_from_dict
from worlds import WorldError

BUNDLED = ("bailey", "bailey-sparse", "webmap", "densemap")


def test_list_worlds_lists_the_bundled_worlds() -> None:
    listed = {name: (kind, desc) for name, kind, desc in list_worlds()}
    assert set(BUNDLED) <= set(listed)
    for name in BUNDLED:
        kind, desc = listed[name]
        assert kind == "planar-slam"
        assert desc.strip() and "\n" not in desc
        assert desc == load_world(name).description


def test_the_built_in_kinds_are_registered() -> None:
    assert {"planar-slam", "drone-slam", "attitude"} <= set(KINDS)
    for name, kind in KINDS.items():
        assert isinstance(kind, Kind) and kind.name == name and get_kind(name) is kind
    with pytest.raises(KeyError):
        get_kind("submarine")
    # the log kinds (planar logs, the default; attitude logs; IMU + GNSS logs, chosen by
    # the path) refuse world files
    readers = [k for k in KINDS.values() if k.open_log is not None]
    assert readers[0] is log_kind() and log_kind().name == "recorded-log"
    assert [k.name for k in readers] == ["recorded-log", "recorded-attitude", "ins-log"]
    assert log_kind("a/b.csv") is log_kind("kitti") is not log_kind("victoria_park.txt")
    for reader in readers:
        with pytest.raises(WorldError, match="--log"):
            world_from_dict({"kind": reader.name}, name="x")


def test_only_drawing_a_figure_imports_matplotlib() -> None:
    """Every kind's run, summary, tables and extra files load without matplotlib (a run
    with ``--no-plots`` starts about half a second sooner); the figures import it."""
    code = ("import sys\n"
            "from slam.registry import KINDS\n"
            "for kind in KINDS.values():\n"
            "    kind.load(); kind.report.text_table, kind.report.extra_files\n"
            "print('before', 'matplotlib' in sys.modules)\n"
            "for kind in KINDS.values():\n"
            "    kind.report.figures()\n"
            "print('after', 'matplotlib' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["before", "False", "after", "True"]


def test_every_bundled_world_loads_through_its_kind() -> None:
    for name, kind, _ in list_worlds():
        assert kind in KINDS, name
        assert load_world(name).kind == kind


@pytest.mark.parametrize(("data", "fragment"), [
    ({}, "kind: missing (required; one of: "),
    ({"kind": "submarine"}, 'kind = "submarine": unknown kind; known: '),
    ({"kind": 3}, "kind = 3: unknown kind"),
])
def test_a_document_without_a_known_kind_names_the_kinds(data, fragment) -> None:
    with pytest.raises(WorldError) as info:
        world_from_dict(data, name="w", source="w.toml")
    text = str(info.value)
    assert info.value.key == "kind" and text.startswith("w.toml: ") and fragment in text
    # the message lists the kinds a world file can have (not the log reader)
    known = text.rsplit(": ", 1)[-1].rstrip(")")
    assert "planar-slam" in known and log_kind().name not in known
    with pytest.raises(WorldError, match="must be a table"):
        world_from_dict([], name="w")  # type: ignore[arg-type]
