"""Finding and reading world files (:mod:`worlds.loader`), directly and through
:func:`slam.registry.load_world`: by name or path, unknown names, TOML syntax errors naming
file and line."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

import worlds
from slam.registry import load_world
from worlds import WorldError, bundled_names, read_world

# the planar validator's minimal world file, up to the line the syntax error goes in
HEAD = """\
kind = "planar-slam"
description = "tiny"
runs = 3
"""


def write(tmp_path: Path, text: str, name: str = "w.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_load_by_path_equals_load_by_name() -> None:
    path = Path(worlds.__file__).parent / "bailey.toml"
    by_path, by_name = load_world(path), load_world("bailey")
    assert by_path.source == str(path)
    assert dataclasses.replace(by_path, source=by_name.source) == by_name


def test_unknown_world_name() -> None:
    with pytest.raises(WorldError, match="bailey"):
        load_world("no-such-world")


def test_toml_syntax_error_names_file_and_line(tmp_path: Path) -> None:
    path = write(tmp_path, HEAD.replace("runs = 3", "runs = = 3"))
    with pytest.raises(WorldError) as info:
        load_world(path)
    err = info.value
    assert err.key is None and err.line == 3
    assert str(err).startswith(f"{path}:3: invalid TOML")


def test_bundled_names_are_the_toml_files() -> None:
    folder = Path(worlds.__file__).parent
    assert bundled_names() == sorted(p.stem for p in folder.glob("*.toml"))
    assert {"bailey", "drone", "star-sensor"} <= set(bundled_names())


def test_read_world_by_name_and_by_path(tmp_path: Path) -> None:
    doc = read_world("bailey")
    assert (doc.name, doc.source) == ("bailey", "worlds/bailey.toml")
    assert doc.data["kind"] == "planar-slam" and doc.base is not None
    path = write(tmp_path, HEAD, name="mine.toml")
    mine = read_world(path)
    assert (mine.name, mine.source, mine.data) == ("mine", str(path),
                                                   {"kind": "planar-slam",
                                                    "description": "tiny", "runs": 3})
    assert Path(str(mine.base)) == tmp_path
    # a string with a path separator or a .toml suffix is a path, not a bundled name
    assert read_world(str(path)).data == mine.data


def test_missing_file_and_non_utf8_text_are_world_errors(tmp_path: Path) -> None:
    with pytest.raises(WorldError, match="no such world file") as info:
        read_world(tmp_path / "absent.toml")
    assert info.value.key is None and info.value.file == str(tmp_path / "absent.toml")
    bad = tmp_path / "latin1.toml"
    bad.write_bytes('description = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(WorldError, match="not UTF-8"):
        read_world(bad)


def test_a_numpy_value_is_shown_as_toml_in_an_error():
    """Cross-key checks compute with numpy; the message shows ``5.0``, not
    ``np.float64(5.0)``."""
    import numpy as np

    from worlds.schema import format_value

    assert format_value(np.float64(5.0)) == "5.0"
    assert format_value(np.array([1.5, 2.0])) == "[1.5, 2.0]"
    assert format_value(np.bool_(True)) == "true" and format_value(np.int64(3)) == "3"
