"""The shared toolkit for validating user input (matrices, thresholds, scenes, command options).

Every reader of user input collects *all* problems as one-line messages and raises them together as
``bench.errors.InputError`` (exit status 2, no traceback). This module holds what those readers share:

* ``suggestion``: the " (did you mean 'x'?)" hint for a misspelt name (``difflib.get_close_matches``);
* ``short_repr`` / ``short_list``: a value or a list shown in a message, cut so that the message stays one short
  line whatever the input holds;
* ``is_number`` / ``finite_number``: a real number (not a bool), and one that is finite (optionally > 0);
* ``built_in_names`` / ``read_toml``: the package's built-in TOML files (``bench/matrices``,
  ``bench/thresholds``, found with ``importlib.resources`` so that they work from a wheel as from a checkout)
  and reading a built-in name or a path into a parsed document;
* the limits an integration setting must respect wherever it is given (a matrix's ``kh``/``tol`` sweeps and
  ``foucault-bench simulate``'s ``--kh``/``--tol``): ``setting_problem`` (one kh or tolerance),
  ``coarse_steps_problem`` (a fixed step is at most one output interval) and ``step_count_problem`` (at most
  ``MAX_STEPS`` fixed steps), so that both refuse the same settings with the same words;
* ``run_timeout_problem``: a per-run time limit (``--run-timeout``, ``run_timeout_s``) within what the
  executors can wait (``MAX_RUN_TIMEOUT_S``).
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

UNIT_ROUNDOFF = 2.0**-53
"""Double-precision unit roundoff u = 2⁻⁵³ (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed., §2.1):
a tolerance below it cannot be met by any double-precision integrator (an adaptive one shrinks its step
without end)."""
MAX_STEPS = 1e10
"""More fixed steps than this in one run is refused (about an hour per run even at 3 ns a step)."""
STEP_FIT_RTOL = 1e-12
"""A kh above k·Δ by less than this (relative) still fits one output interval Δ: k·Δ computed in floating point."""
MAX_RUN_TIMEOUT_S = 1e6
"""Largest per-run time limit (s), 11.6 days. The local executor waits for its workers with
``multiprocessing.connection.wait``, i.e. poll(2), whose timeout is a C int of milliseconds: it overflows above
2³¹ − 1 ms = 2 147 483.647 s (24.9 days; Python raises OverflowError "timeout is too large"). 10⁶ s stays a
factor 2 below that and is 10⁵ times the slowest run of the built-in matrices (bench/README.md "Time limits")."""


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


def git_repository_problem(path: Path, option: str = "--repo") -> str | None:
    """The problem with ``path`` as the git repository of ``option`` (one line), or ``None`` when it is one."""
    return None if (Path(path) / ".git").exists() else f"{option} {path}: not a git repository (no .git in it)"


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


def short_repr(value: Any, limit: int = 80) -> str:
    """``repr(value)``, cut to its first 60 characters and its length when longer than ``limit`` (a message
    stays one short line even for a value of a million characters; ``repr`` escapes newlines)."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:60]}…({len(text)} characters)"


def short_list(items: Iterable[str], limit: int = 10) -> str:
    """The items joined by commas, the first ``limit`` of them and how many there are in all when more."""
    items = list(items)
    shown = ", ".join(items[:limit])
    return shown if len(items) <= limit else f"{shown}, … ({len(items)} in all)"


def setting_problem(key: str, value: Any) -> str | None:
    """Why ``value`` is not a usable ``kh`` (> 0, finite: the step in units of 1/k) or ``tol`` (in (0, 1) and
    at least ``UNIT_ROUNDOFF``), or ``None``. ``key`` is ``"kh"`` or ``"tol"``."""
    if type(value) is not float and not is_number(value):  # the type test first: sweeps are long lists of floats
        return f"{key} entries must be numbers a float can hold, got {short_repr(value)}"
    if key == "kh":
        if not (math.isfinite(value) and value > 0):
            return f"step size must be > 0: kh = {value!r} (kh = k·h, the step in units of 1/k)"
        return None
    if not 0.0 < value < 1.0:
        return f"tolerance must lie in (0, 1): tol = {value!r}"
    if value < UNIT_ROUNDOFF:
        return (f"tol = {value!r} is below the double-precision unit roundoff 2^-53 ≈ 1.1e-16: "
                "no double-precision integrator can meet it")
    return None


def coarse_steps_problem(kh_values: Iterable[float], frequency_rad_s: float, output_interval_s: float,
                         what: str) -> str | None:
    """A fixed step is at most one output interval Δ (``integrators.fixed_step``): the kh values above k·Δ, in
    one message naming ``what`` (e.g. "scene 'pantheon'"), or ``None``."""
    largest = frequency_rad_s * output_interval_s
    too_coarse = [value for value in kh_values if value > largest * (1.0 + STEP_FIT_RTOL)]
    if not too_coarse:
        return None
    return (f"kh = {short_list(f'{value:g}' for value in too_coarse)} exceeds what {what} allows: a step is at "
            f"most one output interval, kh <= k·Δ = {largest:.4g}")


def step_count_problem(kh: float, frequency_rad_s: float, duration_s: float, what: str) -> str | None:
    """A fixed step of ``kh`` needs duration·k/kh steps: more than ``MAX_STEPS`` is refused, with the estimate."""
    steps = duration_s * frequency_rad_s / kh
    if steps <= MAX_STEPS:
        return None
    return (f"kh = {kh:g} needs about {steps:.2g} steps in {what} (duration {duration_s:g} s · k "
            f"{frequency_rad_s:.4g} rad/s / kh), more than {MAX_STEPS:.0e}")


def run_timeout_problem(value: Any, where: str) -> str | None:
    """Why ``value`` is not a usable per-run time limit (a number of seconds in (0, ``MAX_RUN_TIMEOUT_S``]),
    or ``None``."""
    if not finite_number(value, positive=True):
        return f"{where} must be a finite number of seconds > 0, got {short_repr(value)}"
    if value > MAX_RUN_TIMEOUT_S:
        return (f"{where} = {value:g} s is more than {MAX_RUN_TIMEOUT_S:.0e} s (11.6 days), the longest limit the "
                "run executors can wait for (their poll(2) timeout overflows at 2^31 ms ≈ 24.9 days)")
    return None
