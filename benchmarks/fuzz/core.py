"""Shared pieces of the mutators: the :class:`Case` and :class:`Base` records, cheap base
worlds, and key paths into parsed TOML documents."""

from __future__ import annotations

import copy
import hashlib
import random
import tomllib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from . import tomlio

Key = str | int
KeyPath = tuple[Key, ...]
F = TypeVar("F", bound=Callable[..., Any])
LOG_KIND = "recorded-log"
"""The ``world_kind`` of a log case."""


@dataclass(frozen=True)
class Case:
    """One generated input for ``slam run``.

    ``data`` is the file's content (``None`` when ``target`` names an existing path such
    as ``/dev/zero`` to pass instead); ``extra`` maps relative paths to side files
    written next to it (a map or mesh file the world names); ``world_kind`` is the base
    world's ``kind`` (``recorded-log`` for a log); ``plots`` runs the case with figures.
    """

    kind: str  # "world" | "log"
    family: str
    name: str
    base: str
    data: bytes | None
    extra: tuple[tuple[str, bytes], ...] = ()
    target: str | None = None
    world_kind: str = ""
    plots: bool = False

    @property
    def ident(self) -> str:
        """A file-name-safe identifier (family + base + a hash of the content)."""
        h = hashlib.sha1((self.name + self.base).encode() + (self.data or b"")).hexdigest()
        return f"{self.kind}-{self.family}-{self.base}-{h[:10]}"


@dataclass(frozen=True)
class Base:
    """A bundled world, parsed and made cheap, with the data files it names."""

    name: str
    doc: dict[str, Any]
    extra: tuple[tuple[str, bytes], ...] = field(default=())

    @property
    def kind(self) -> str:
        """The world's ``kind`` key."""
        return str(self.doc.get("kind", "?"))


# --------------------------------------------------------------------------- bases

def cheapen(doc: dict[str, Any]) -> dict[str, Any]:
    """A copy of a world document that runs in seconds: one filter (srckf if listed, the
    paper's first where the world names a paper model, else the first listed), attitude
    runs <= 40 s,
    planar worlds one loop (drone worlds keep theirs: with one loop the bundled drone
    worlds already fail in the smoother, which the fuzzing should find, not start from)."""
    doc = copy.deepcopy(doc)
    veh = doc.get("vehicle")
    if isinstance(veh, dict) and "loops" in veh and doc.get("kind") == "planar-slam":
        veh["loops"] = 1
    filt = doc.get("filters")
    if isinstance(filt, dict) and "names" in filt:
        names = filt["names"] if isinstance(filt["names"], list) else []
        keep = "srckf" if "srckf" in names or not names else str(names[0])
        paper = filt.get("paper_model")
        if isinstance(paper, list) and paper:  # ship: paper_model must be among the names
            keep = paper[0]
            filt["paper_model"] = [keep]
        if isinstance(filt.get("variants"), list):
            filt["variants"] = [v for v in filt["variants"] if str(v).startswith(f"{keep}:")]
        filt["names"] = [keep]
    if (isinstance(doc.get("duration_s"), int | float) and doc["duration_s"] > 40
            and "flight" not in doc):  # a flight plan is tied to its duration
        doc["duration_s"] = 40.0
        score = doc.get("scoring")
        for key in ("steady_state_from_s", "settled_from_s"):  # ship, alignment
            if isinstance(score, dict) and score.get(key, 0) > 20:
                score[key] = 20.0
    sweep = doc.get("sweep")
    if isinstance(sweep, dict) and isinstance(sweep.get("runs"), int) and sweep["runs"] > 1:
        sweep["runs"] = 1  # the alignment gamma sweep: one run's cells
    mp = doc.get("map")
    if isinstance(mp, dict) and "file" in mp and isinstance(filt, dict):
        filt["mode"] = "local"  # map files hold the big maps (densemap: 135 landmarks)
    return doc


def load_bases(worlds_dir: Path) -> list[Base]:
    """Every ``*.toml`` in ``worlds_dir``, cheapened, with the map files they name."""
    bases = []
    for path in sorted(worlds_dir.glob("*.toml")):
        doc = cheapen(tomllib.loads(path.read_text(encoding="utf-8")))
        extra: list[tuple[str, bytes]] = []
        rel = doc.get("map", {}).get("file")
        if isinstance(rel, str) and not Path(rel).is_absolute():
            src = worlds_dir / rel
            if not src.is_file():  # the data folder may have moved: find it by name
                src = next(iter(sorted(worlds_dir.parent.rglob(Path(rel).name))), src)
            extra.append((rel, src.read_bytes()))
        bases.append(Base(path.stem, doc, tuple(extra)))
    if not bases:
        raise FileNotFoundError(f"no *.toml world files in {worlds_dir}")
    return bases


def render(base: Base, family: str, name: str, doc: dict[str, Any] | None = None,
           text: str | bytes | None = None, extra: dict[str, bytes] | None = None) -> Case:
    """A world :class:`Case` from a mutated document or raw text/bytes."""
    if text is None:
        text = tomlio.dumps(doc if doc is not None else base.doc)
    data = text.encode("utf-8") if isinstance(text, str) else text
    files = dict(base.extra)
    files.update(extra or {})
    return Case("world", family, name, base.name, data, tuple(sorted(files.items())),
                world_kind=base.kind)


# --------------------------------------------------------------------------- key paths

def dotted(path: KeyPath) -> str:
    """``("map", "landmarks", 3, 1)`` -> ``"map.landmarks[3][1]"``."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


def walk(doc: Any, path: KeyPath = (), items: bool = True) -> list[KeyPath]:
    """Paths to every value below ``doc`` (tables, arrays and, with ``items``, elements)."""
    out: list[KeyPath] = []
    if isinstance(doc, dict):
        for k, v in doc.items():
            out.append((*path, k))
            out.extend(walk(v, (*path, k), items))
    elif isinstance(doc, list) and items:
        for i, v in enumerate(doc):
            out.append((*path, i))
            out.extend(walk(v, (*path, i), items))
    return out


def get(doc: Any, path: KeyPath) -> Any:
    """The value at ``path``."""
    for p in path:
        doc = doc[p]
    return doc


def put(doc: Any, path: KeyPath, v: Any) -> None:
    """Set the value at ``path`` (its parent must exist)."""
    get(doc, path[:-1])[path[-1]] = v


def is_num(v: Any) -> bool:
    """An int or float, not a bool."""
    return isinstance(v, int | float) and not isinstance(v, bool)


def pick(rng: random.Random, doc: dict[str, Any], want: Callable[[Any], bool],
         items: bool = True) -> KeyPath | None:
    """A random path whose value passes ``want``: outside ``[paper]`` nine times in ten,
    and a named key (not an array element) three times in four when there is one."""
    paths = [p for p in walk(doc, items=items) if want(get(doc, p))]
    if not paths:
        return None
    main = [p for p in paths if p[0] != "paper"]
    pool = main if main and rng.random() < 0.9 else paths
    keyed = [p for p in pool if not any(isinstance(k, int) for k in p)]
    if keyed and rng.random() < 0.75:
        pool = keyed
    return rng.choice(pool)


def seeded_families(n: int, seed: int, stream: str,
                    names: list[str]) -> Iterator[tuple[random.Random, str]]:
    """For case ``i`` of ``n``: its generator (seeded by ``seed``, the ``stream``'s name and
    ``i``) and its family, ``names[i mod F]``."""
    for i in range(n):
        yield random.Random(f"{seed}:{stream}:{i}"), names[i % len(names)]


def registrar(table: dict[str, F]) -> Callable[[str], Callable[[F], F]]:
    """A decorator factory for ``table``: ``@mutator(name)`` (``mutator = registrar(table)``)
    adds the function below it to ``table`` under ``name``, so a family's name stands at its
    definition and the table keeps definition order."""
    def mutator(name: str) -> Callable[[F], F]:
        def add(fn: F) -> F:
            if name in table:
                raise ValueError(f"mutator family {name!r} defined twice")
            table[name] = fn
            return fn
        return add
    return mutator


ELF_HEADER = ("ELF header", b"\x7fELF\x02\x01\x01" + bytes(57))
"""The junk variant that is an executable's header."""


def binary_junk(rng: random.Random, text: bytes, at: int) -> list[tuple[str, bytes]]:
    """Named binary variants of ``text``: random bytes, and a NUL byte or invalid UTF-8
    inserted at byte ``at``, the text in UTF-16, behind a UTF-8 BOM."""
    return [
        ("random bytes", rng.randbytes(rng.choice([1, 64, 4096]))),
        ("NUL byte inserted", text[:at] + b"\x00" + text[at:]),
        ("invalid UTF-8 inserted", text[:at] + b"\xff\xfe" + text[at:]),
        ("UTF-16 encoded", text.decode().encode("utf-16")),
        ("UTF-8 BOM", b"\xef\xbb\xbf" + text),
    ]


def binary_variant(rng: random.Random, text: bytes) -> tuple[str, bytes]:
    """One of :func:`binary_junk`'s variants of ``text`` at a random byte, or an ELF
    header: ``("<what> (at byte <n>)", the bytes)``."""
    at = rng.randrange(len(text))
    name, data = rng.choice([*binary_junk(rng, text, at), ELF_HEADER])
    return f"{name} (at byte {at})", data
