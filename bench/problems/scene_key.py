"""A scene's key: a short hash of its physics, so that rows are told apart by what was integrated, not by a name.

A scene name is chosen by whoever writes a matrix file: an inline scene may reuse a built-in name, or a name an
earlier matrix gave other physics. Everything that groups, matches or picks the latest rows of "a scene" (``advise``,
``results --compare``, the report) uses ``scene_key``: a SHA-256 of the scene's physics (``physics_identity``:
model, every pendulum parameter including the release, duration, output interval) as canonical JSON, stored
with every row (``bench.schema`` column ``scene_key``).

Canonical means the same bytes for the same physics on every machine, run and Python version: keys sorted,
no whitespace, every number as the exact hexadecimal form of its double (``float.hex``: ``67`` and ``67.0`` give one
key, two doubles one ulp apart two keys), booleans as JSON booleans.

``scene_labels`` names the scenes of a set of rows for display: the plain name where a name has one physics,
``name [key6]`` (the key's first six hex digits) where one name stands for several, so that they are never
merged.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from typing import TYPE_CHECKING, Any, Iterable

if TYPE_CHECKING:
    import pandas as pd

    from foucault_bench.bench.problems.scenes import Scene

SCENE_KEY_HEX_DIGITS = 16
"""Length of a stored key (64 bits: a collision among a million scenes has odds about 3e-8)."""
LABEL_HEX_DIGITS = 6
"""Digits of the key shown in a label when one name has several physics."""
UNKNOWN_KEY_LABEL = "unknown physics"
"""Label part of rows whose physics is not known (``scene_key`` NULL: rows of an older database)."""


def physics_identity(scene: Scene) -> dict[str, Any]:
    """The scene fields that determine its trajectory (not its name or texts). A refinement's parameter
    (``models.parameters.rule(refinement=True)``: support anisotropy, drag, drive) at its default changes nothing
    and is left out, so that a field added with such a default keeps the keys of every stored scene."""
    fields = {field.name: field for field in dataclasses.fields(scene.params)}
    params = {name: value for name, value in dataclasses.asdict(scene.params).items()
              if not (fields[name].metadata.get("refinement") and value == fields[name].default)}
    return {
        "model": scene.model,
        "params": params,
        "duration_s": scene.duration_s,
        "output_interval_s": scene.output_interval_s,
    }


def _canonical(value: Any) -> Any:
    """``value`` with every number replaced by ``float.hex`` of its double, tuples as lists (JSON-ready)."""
    if isinstance(value, bool):
        return value
    if isinstance(value, dict):
        return {str(key): _canonical(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_canonical(item) for item in value]
    if isinstance(value, str):
        return value
    number = float(value)  # ints and numpy scalars: the double the integrators compute with
    if not math.isfinite(number):
        raise ValueError(f"a scene's physics holds a non-finite number {value!r}")
    return number.hex()


def scene_key(scene: Scene) -> str:
    """The scene's key: SHA-256 (``SCENE_KEY_HEX_DIGITS`` hex digits) of its canonical physics (module
    docstring)."""
    text = json.dumps(_canonical(physics_identity(scene)), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:SCENE_KEY_HEX_DIGITS]


def scene_labels(rows: pd.DataFrame, among: pd.DataFrame | None = None) -> pd.Series:
    """One display name per row of ``rows`` (columns ``scene`` and, where known, ``scene_key``): the scene's
    name where that name has one physics among ``rows`` and ``among``, else ``name [key6]`` (more digits if six
    do not tell that name's keys apart), or ``name [unknown physics]`` for rows without a key. Without a
    ``scene_key`` column the names are kept."""
    import pandas as pd

    frames = [rows] if among is None else [rows, among]
    if any("scene_key" not in frame.columns for frame in frames):
        return rows["scene"].astype(str)
    labels = label_map(pair for frame in frames for pair in zip(frame["scene"], frame["scene_key"], strict=True))
    return pd.Series([labels[_pair(name, key)] for name, key in zip(rows["scene"], rows["scene_key"], strict=True)],
                     index=rows.index, dtype=object)


def label_map(pairs: Iterable[tuple[str, Any]]) -> dict[tuple[str, str | None], str]:
    """(name, key) → display label for every (name, scene key) pair given (``scene_labels``; a missing key is
    ``None`` or NaN). Plain Python: the summary printed after a run imports no pandas."""
    keys: dict[str, set[str | None]] = {}
    for name, key in pairs:
        keys.setdefault(str(name), set()).add(_pair(name, key)[1])
    labels = {}
    for name, found in keys.items():
        digits = _distinguishing_digits({key for key in found if key is not None})
        for key in found:
            shown = UNKNOWN_KEY_LABEL if key is None else key[:digits]
            labels[name, key] = name if len(found) == 1 else f"{name} [{shown}]"
    return labels


def _pair(name: Any, key: Any) -> tuple[str, str | None]:
    return str(name), key if isinstance(key, str) else None


def _distinguishing_digits(keys: set[str]) -> int:
    """The fewest leading hex digits, at least ``LABEL_HEX_DIGITS``, that tell ``keys`` apart."""
    digits = LABEL_HEX_DIGITS
    while len({key[:digits] for key in keys}) < len(keys):
        digits += 1
    return digits
