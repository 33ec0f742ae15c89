"""The report's figure cache: a figure whose inputs did not change since the previous build of the same folder is
taken from that build instead of being drawn again.

Each figure has a key (``digest``): a SHA-256 over everything its drawing reads (the results rows or study table
it is given, hashed by value with ``pandas.util.hash_pandas_object``, its caption, file stem and options, the
drawing functions by name) and the drawing code's version (``code_version``: the source of every module of the
package and the versions of the drawing libraries), so a changed row redraws exactly the figures given that row
and a changed line of code redraws everything. The cache lives in the report folder (``cache/figures.json``: key
→ the figure's blocks, plotly JSON included) and travels with it; ``cache/last_build.json`` lists the figures a
build drew and those it reused. A reused figure's static PNG and SVG files are copied from the previous folder.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import shutil
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pandas as pd

from foucault_bench.bench.provenance import PACKAGE_ROOT, source_digest
from foucault_bench.reports.document import Block, Figure, Heading, Paragraph

CACHE_FOLDER = "cache"
CACHE_FILE = "figures.json"
BUILD_LOG = "last_build.json"
PACKAGES = ("models", "integrators", "bench", "reports")
"""The sub-packages whose sources make the code version."""
LIBRARIES = ("matplotlib", "plotly", "numpy", "pandas")


@functools.cache
def code_version() -> str:
    """A hash of the source of every module of the package and of the drawing libraries' versions
    (``bench.provenance.source_digest``, as run keys hash theirs)."""
    paths = sorted(path for package in PACKAGES for path in (PACKAGE_ROOT / package).rglob("*.py"))
    return source_digest(",".join(f"{library}={version(library)}" for library in LIBRARIES), paths)


class Unhashable(TypeError):
    """A figure input the key cannot see through (a lambda, a closure, an object of unknown kind): the figure
    is drawn on every build."""


def _feed(sha, value: object, folder: Path) -> None:
    """Hash ``value`` into ``sha`` by what it holds (paths relative to ``folder``: the staging folder's name
    changes from build to build)."""
    if isinstance(value, pd.DataFrame):
        sha.update(b"frame" + json.dumps([[str(c), str(t)] for c, t in value.dtypes.items()]).encode())
        sha.update(pd.util.hash_pandas_object(value, index=False).to_numpy().tobytes())
    elif isinstance(value, pd.Series):
        sha.update(b"series" + str(value.name).encode() + str(value.dtype).encode())
        sha.update(pd.util.hash_pandas_object(value, index=False).to_numpy().tobytes())
    elif isinstance(value, functools.partial):
        sha.update(b"partial")
        for part in (value.func, value.args, value.keywords):
            _feed(sha, part, folder)
    elif isinstance(value, dict):
        sha.update(b"dict")
        for key in sorted(value, key=repr):
            _feed(sha, key, folder)
            _feed(sha, value[key], folder)
    elif isinstance(value, (list, tuple)):
        sha.update(f"seq{len(value)}".encode())
        for item in value:
            _feed(sha, item, folder)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        sha.update(type(value).__qualname__.encode())
        _feed(sha, {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}, folder)
    elif isinstance(value, Path):
        sha.update(b"path" + (value.relative_to(folder).as_posix() if value.is_relative_to(folder)
                              else str(value)).encode())
    elif callable(value):
        name = getattr(value, "__qualname__", "<unnamed>")
        if getattr(value, "__closure__", None) or "<" in name:  # what a closure or lambda reads is not seen
            raise Unhashable(f"{name} is not a module-level function")
        sha.update(f"callable {value.__module__}.{name}".encode())
    elif isinstance(value, (np.generic, float, int, str, bool, bytes)) or value is None:
        sha.update(f"{type(value).__name__} {value!r}".encode())
    else:
        raise Unhashable(f"cannot hash a {type(value).__name__} as a figure input")


def digest(value: object, folder: Path) -> str:
    """The key of a figure whose drawing reads ``value`` (module docstring); ``Unhashable`` when ``value`` holds
    something whose content the key cannot see."""
    sha = hashlib.sha256(code_version().encode())
    _feed(sha, value, folder)
    return sha.hexdigest()


_BLOCK_TYPES = {kind.__name__: kind for kind in (Figure, Heading, Paragraph)}


def _to_json(blocks: list[Block]) -> list[dict] | None:
    """The blocks as JSON objects; ``None`` when one is of a kind the cache does not keep (a table)."""
    if not all(type(block).__name__ in _BLOCK_TYPES for block in blocks):
        return None
    return [{"kind": type(block).__name__, **dataclasses.asdict(block)} for block in blocks]


def _from_json(entries: list[dict]) -> list[Block]:
    blocks: list[Block] = []
    for entry in entries:
        fields = {key: value for key, value in entry.items() if key != "kind"}
        if entry["kind"] == "Paragraph" and fields.get("link") is not None:
            fields["link"] = tuple(fields["link"])
        blocks.append(_BLOCK_TYPES[entry["kind"]](**fields))
    return blocks


def _static_files(blocks: list[Block]) -> list[str]:
    return [f"{block.stem}.{suffix}" for block in blocks if isinstance(block, Figure) and block.static
            for suffix in ("png", "svg")]


class FigureCache:
    """The cache of the build writing ``folder``, read from ``previous`` (the previous build of that report)."""

    def __init__(self, folder: Path, previous: Path):
        self.folder, self.previous = folder, previous
        self._entries: dict[str, list[dict]] | None = None

    def _previous_entries(self) -> dict[str, list[dict]]:
        if self._entries is None:
            try:
                stored = json.loads((self.previous / CACHE_FOLDER / CACHE_FILE).read_text(encoding="utf-8"))
                self._entries = dict(stored["entries"]) if stored.get("code") == code_version() else {}
            except (OSError, ValueError, KeyError, TypeError):
                self._entries = {}
        return self._entries

    def reuse(self, key: str) -> list[Block] | None:
        """The blocks stored under ``key`` by the previous build, its static files copied into this build's
        folder; ``None`` when it has none (or lost a file)."""
        entries = self._previous_entries().get(key)
        if entries is None:
            return None
        blocks = _from_json(entries)
        files = _static_files(blocks)
        if not all((self.previous / name).is_file() for name in files):
            return None
        if self.previous.resolve() != self.folder.resolve():
            for name in files:
                (self.folder / name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(self.previous / name, self.folder / name)
        return blocks

    def write(self, entries: dict[str, list[Block]], drawn: list[str], reused: list[str]) -> None:
        """Store this build's figures (``entries``: key → blocks) and the list of those it drew and reused."""
        folder = self.folder / CACHE_FOLDER
        folder.mkdir(parents=True, exist_ok=True)
        kept = {key: found for key, blocks in entries.items() if (found := _to_json(blocks)) is not None}
        (folder / CACHE_FILE).write_text(json.dumps({"code": code_version(), "entries": kept}), encoding="utf-8")
        (folder / BUILD_LOG).write_text(json.dumps({"drawn": drawn, "reused": reused}, indent=1) + "\n",
                                        encoding="utf-8")
