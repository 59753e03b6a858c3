"""Finding and reading world files (:mod:`worlds.loader`), directly and through
:func:`slam.registry.load_world`: by name or path, unknown names, TOML syntax errors naming
file and line."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

import worlds
import worlds.loader
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


@pytest.mark.parametrize(("text", "line"), [
    (HEAD + ".".join(["a"] * 2000) + " = 1\n", 4),  # a dotted key
    (HEAD + "[" + ".".join(["t"] * 40) + "]\nx = 1\n", 4),  # a table header
    (HEAD + '"""\nthree\nlines\n"""\n[[' + ".".join(['"q"'] * 33) + "]]\n", 8),  # quoted parts
    (HEAD + "x = {" + " . ".join(["b"] * 100) + " = 2}\n", 4),  # in an inline table
])
def test_a_long_dotted_key_is_refused_before_parsing(tmp_path: Path, text: str, line: int):
    """tomllib's memory grows with the square of a dotted key's parts (30 000 parts: 4 GB):
    the key is refused before parsing, naming the file and line (issue 24)."""
    path = write(tmp_path, text)
    with pytest.raises(WorldError) as info:
        read_world(path)
    assert info.value.line == line, str(info.value)
    assert str(info.value).startswith(f"{path}:{line}: a dotted key or table header of ")
    assert "parts; at most 32 are allowed" in str(info.value)


def test_dots_in_strings_and_comments_and_short_keys_are_not_key_parts(tmp_path: Path):
    dots = "." * 200
    text = (HEAD.replace('"tiny"', f'"{dots}"') + f"# {dots}\n"
            + "[" + ".".join(["t"] * 20) + "]\n" + f"s = '{dots}'\nf = [1.5, 2.5]\n"
            + f'm = """\n{dots}\n"""\n')
    doc = read_world(write(tmp_path, text))
    assert doc.data["description"] == dots
    # the bundled worlds' keys have at most 3 parts, far below the limit
    for name in bundled_names():
        raw = (Path(worlds.__file__).parent / f"{name}.toml").read_text(encoding="utf-8")
        worlds.loader.check_key_parts(raw, name)
