"""The shared toolkit for validating user input (matrices, thresholds, scenes, command options).

Every reader of user input collects *all* problems as one-line messages and raises them together as
``bench.errors.InputError`` (exit status 2, no traceback). This module holds what those readers share:

* ``suggestion``: the " (did you mean 'x'?)" hint for a misspelt name (``difflib.get_close_matches``);
* ``is_number`` / ``finite_number``: a real number (not a bool), and one that is finite (optionally > 0);
* ``built_in_names`` / ``read_toml``: the package's built-in TOML files (``bench/matrices``,
  ``bench/thresholds``, found with ``importlib.resources`` so that they work from a wheel as from a checkout)
  and reading a built-in name or a path into a parsed document.
"""

from __future__ import annotations

import difflib
import importlib.resources
import math
import numbers
import tomllib
from pathlib import Path
from typing import Any, Iterable, TypeGuard

from foucault_bench.bench.errors import InputError

DATA_PACKAGE = "foucault_bench.bench"
"""The package whose folders hold the built-in TOML files (package data, see pyproject.toml)."""


def suggestion(word: Any, choices: Iterable[Any]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``choices`` to ``word``, or ``""`` when none is close."""
    close = difflib.get_close_matches(str(word), [str(choice) for choice in choices], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def is_number(value: Any) -> TypeGuard[float]:
    """A real number a float can hold (``numbers.Real``: int, float and numpy's scalars register there), but not
    a bool, nor an int too large for a float (10**400 would raise OverflowError in every later comparison)."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        return False
    try:
        float(value)
    except OverflowError:
        return False
    return True


def finite_number(value: Any, *, positive: bool = False) -> bool:
    """A finite real number (``is_number``), strictly positive when ``positive``."""
    return is_number(value) and math.isfinite(value) and (not positive or value > 0)


def built_in_names(folder: str) -> list[str]:
    """Names (file stems) of the ``*.toml`` files shipped in the package folder ``folder``."""
    directory = importlib.resources.files(DATA_PACKAGE).joinpath(folder)
    return sorted(entry.name.removesuffix(".toml") for entry in directory.iterdir() if entry.name.endswith(".toml"))


def read_toml(name_or_path: str | Path, *, folder: str, kind: str) -> tuple[dict[str, Any], str, Path | None]:
    """Read a built-in TOML file of ``folder`` by name, or a TOML file by path.

    Returns (document, source, directory): ``source`` names the file in messages (``built-in matrix 'quick'``
    or the path) and ``directory`` is the file's folder (``None`` for a built-in). ``kind`` (``matrix``,
    ``thresholds``) words the messages. Raises ``InputError`` when neither exists, the file cannot be read or
    it is not valid TOML.
    """
    text_name = str(name_or_path)
    path = Path(name_or_path)
    built_ins = built_in_names(folder)
    if text_name in built_ins and not path.exists():
        resource = importlib.resources.files(DATA_PACKAGE).joinpath(folder, f"{text_name}.toml")
        text, source, directory = resource.read_text(encoding="utf-8"), f"built-in {kind} {text_name!r}", None
    elif path.is_file():
        try:
            text, source, directory = path.read_text(encoding="utf-8"), str(path), path.parent
        except (OSError, UnicodeDecodeError) as error:
            raise InputError(f"{path}: cannot read the {kind} file: {error}") from None
    else:
        raise InputError(f"{kind} {text_name!r} is neither a readable file nor a built-in {kind} file"
                         f"{suggestion(text_name, built_ins)}; built-in {kind} files: {', '.join(built_ins)}")
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:  # its message carries "(at line L, column C)"
        raise InputError(f"{source}: not valid TOML: {error}") from None
    return document, source, directory
