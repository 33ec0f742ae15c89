"""``foucault-bench check``: a CI gate that checks results against a thresholds file.

A thresholds file (TOML, read with ``tomllib``) is a list of bounds. Each bound selects rows of the results table
(``bench.schema``) by scene, integrator (or family) and setting, and states what must hold for them::

    description = "what this gate protects"
    matrix = "quick"                 # run when check gets neither --results nor --matrix (a built-in name,
                                     # or a path relative to this file)

    [[bound]]
    scene = "pantheon"               # a scene name or a list of names (required)
    integrator = "rk4"               # a name or a list of names; or family = "runge-kutta" (one of the two)
    kh = 0.25                        # setting: kh = number or list, tol = number or list, or kh_min / kh_max
                                     # (inclusive, on the stored effective kh); none of them = every setting
    column = "precession_rate_ref_error"
    max = 1e-6                       # the kind of bound: exactly one of the keys of BOUND_KINDS
    basis = "theory: ..."            # where the number comes from (printed with a failure)

Kinds of bound (``BOUND_KINDS``):

* ``max``, ``min``, ``max_abs`` on a column: checked on every selected row, which must also have status ``ok``;
* ``status = "diverged"`` (or ``ok``, ``failed``): every selected row has that status;
* ``min_order`` on an error column: the convergence order fitted across the fixed-step sweep of each selected
  scene × integrator (``bench.verdicts.convergence.observed_order`` on the effective step sizes), at least 3 settings;
* ``max_ratio`` with ``relative_to``: column of the row ÷ column of another integrator's row of the same scene,
  measured in the same matrix run (the only way to bound wall time or memory: ``MACHINE_COLUMNS``).
  ``relative_to = "rk4"`` compares with rk4 at the row's own setting; ``relative_to = {integrator = "rk4",
  kh = 0.25}`` (or ``tol``) at a fixed one.

Setting match: the fixed-step loop shortens the requested step to fit a whole number of steps in each output
interval (``integrators.fixed_step.uniform_output_stride``), so a stored row holds the effective kh. A bound's
``kh`` matches a row whose kh equals the requested value or the effective step that value gives on the row's
own output grid (spacing = duration_s / (n_out − 1), k = kh / step_s of the row).

Margin (the table's ``margin`` column): the headroom factor when the bound and the measured value are both
positive (bound ÷ measured for an upper bound, measured ÷ bound for a lower one; below 1 fails), otherwise the
difference (bound − measured, or measured − bound; below 0 fails).

Exit status: 0 when every bound holds, 1 when any fails, 2 on bad input (``bench.errors.InputError``: malformed
TOML, an unknown key, scene, integrator, family or column, a bound that selects no row) — bad input is found
before a matrix is run.
"""

from __future__ import annotations

import argparse
import difflib
import importlib.resources
import math
import sys
import tempfile
import tomllib
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Sequence

import numpy as np
import pandas as pd

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.schema import COLUMN_NAMES, RUN_STATUSES, VERDICT_COLUMNS
from foucault_bench.bench.run.store import setting_label

if TYPE_CHECKING:  # for annotations only: bench.run.matrix imports the scenes and the integrators
    from foucault_bench.bench.run.matrix import Matrix

BUILT_IN_DIRECTORY = "thresholds"
TOP_LEVEL_KEYS = ("description", "matrix", "bound")
SELECTION_KEYS = ("scene", "integrator", "family", "kh", "tol", "kh_min", "kh_max")
BOUND_KINDS = ("max", "min", "max_abs", "status", "min_order", "max_ratio")
UPPER_BOUNDS = ("max", "max_abs", "max_ratio")
OTHER_KEYS = ("column", "relative_to", "basis")
BOUND_KEYS = SELECTION_KEYS + BOUND_KINDS + OTHER_KEYS
STATUSES = RUN_STATUSES

ERROR_COLUMNS: tuple[str, ...] = tuple(name for name in VERDICT_COLUMNS if name != "energy_drift_per_s")
"""Non-negative error columns: the ones a convergence order can be fitted to."""
VALUE_COLUMNS: tuple[str, ...] = (*VERDICT_COLUMNS, "precession_rate_rad_s", "nfev", "njev", "steps",
                                  "rejected_steps")
"""Deterministic columns that ``max``, ``min`` and ``max_abs`` may bound."""
MACHINE_COLUMNS: tuple[str, ...] = ("wall_time_s", "wall_time_spread_s", "compile_time_s", "peak_rss_mb")
"""Columns that depend on the machine and its load: bounded only as ratios within one matrix run."""
RATIO_COLUMNS: tuple[str, ...] = (*VALUE_COLUMNS, *MACHINE_COLUMNS)

SETTING_RELATIVE_TOLERANCE = 1e-9
"""Two settings (kh or tol) are the same when they agree to this relative tolerance (float round-trips)."""
MIN_ORDER_SETTINGS = 3
"""Fewest fixed-step settings a ``min_order`` bound fits through: two points always lie on a line, so only a
third can show that the sweep is in the asymptotic regime."""


@dataclass(frozen=True)
class Selection:
    """Which rows a bound applies to. ``integrators`` and ``family`` are exclusive; so are the three setting
    forms (``kh``, ``tol``, ``kh_min``/``kh_max``)."""

    scenes: tuple[str, ...]
    integrators: tuple[str, ...] = ()
    family: str | None = None
    kh: tuple[float, ...] = ()
    tol: tuple[float, ...] = ()
    kh_min: float | None = None
    kh_max: float | None = None


@dataclass(frozen=True)
class Counterpart:
    """The other integrator of a ``max_ratio`` bound, at the row's own setting or at a fixed kh or tol."""

    integrator: str
    kh: float | None = None
    tol: float | None = None


@dataclass(frozen=True)
class Bound:
    """One bound of a thresholds file (``number`` counts from 1 in file order)."""

    number: int
    selection: Selection
    kind: str
    limit: float | str
    column: str | None = None
    relative_to: Counterpart | None = None
    basis: str = ""

    @property
    def label(self) -> str:
        """What must hold, e.g. ``precession_rate_ref_error <= 1e-06``."""
        if self.kind == "status":
            return f"status = {self.limit}"
        if self.kind == "min_order":
            return f"order of {self.column} >= {self.limit:g}"
        if self.kind == "max_ratio":
            return f"{self.column} / {self.relative_to.integrator}'s <= {self.limit:g}"
        operator = {"max": "<=", "min": ">=", "max_abs": "<="}[self.kind]
        column = f"abs({self.column})" if self.kind == "max_abs" else self.column
        return f"{column} {operator} {self.limit:g}"


@dataclass(frozen=True)
class Thresholds:
    """A validated thresholds file. ``matrix`` is the matrix it names (a built-in name or a path; a relative
    path is resolved against ``directory``, the file's own directory, when a file is there)."""

    description: str
    matrix: str | None
    bounds: tuple[Bound, ...]
    source: str
    directory: Path | None = None

    def matrix_to_run(self) -> str | None:
        if self.matrix is None or self.directory is None or Path(self.matrix).is_absolute():
            return self.matrix
        beside = self.directory / self.matrix
        return str(beside) if beside.is_file() else self.matrix


@dataclass(frozen=True)
class Outcome:
    """One checked line: a bound on one row (or, for ``min_order``, on one scene × integrator sweep)."""

    bound: Bound
    scene: str
    integrator: str
    setting: str
    measured: float | str
    margin: float | None
    passed: bool
    detail: str = ""
    margin_is_factor: bool = False


# --- reading a thresholds file ----------------------------------------------------------------------------------


def built_in_thresholds() -> list[str]:
    """Names of the thresholds files shipped with the package (``bench/thresholds/NAME.toml``)."""
    directory = importlib.resources.files("foucault_bench.bench").joinpath(BUILT_IN_DIRECTORY)
    return sorted(entry.name.removesuffix(".toml") for entry in directory.iterdir() if entry.name.endswith(".toml"))


def load_thresholds(name_or_path: str | Path) -> Thresholds:
    """Read and validate a thresholds file: a built-in name (``default``) or a path. ``InputError`` lists every
    problem found."""
    path = Path(name_or_path)
    built_ins = built_in_thresholds()
    directory = None
    if str(name_or_path) in built_ins and not path.exists():
        resource = importlib.resources.files("foucault_bench.bench").joinpath(BUILT_IN_DIRECTORY, f"{name_or_path}.toml")
        text, source = resource.read_text(encoding="utf-8"), f"built-in thresholds {str(name_or_path)!r}"
    elif path.is_file():
        try:
            text, source, directory = path.read_text(encoding="utf-8"), str(path), path.parent
        except (OSError, UnicodeDecodeError) as error:
            raise InputError(f"{path}: cannot read the thresholds file: {error}") from None
    else:
        raise InputError(f"thresholds {str(name_or_path)!r} is neither a readable file nor a built-in thresholds file"
                         f"{_suggestion(str(name_or_path), built_ins)}; built-in: {', '.join(built_ins)}")
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:  # its message carries "(at line L, column C)"
        raise InputError(f"{source}: not valid TOML: {error}") from None
    return parse_thresholds(document, source=source, directory=directory)


def parse_thresholds(document: dict[str, Any], *, source: str = "thresholds",
                     directory: Path | None = None) -> Thresholds:
    """Validate a parsed thresholds document (module docstring); ``InputError`` with every problem."""
    problems: list[str] = []
    for key in document:
        if key not in TOP_LEVEL_KEYS:
            problems.append(f"{source}: unknown key {key!r}{_suggestion(key, TOP_LEVEL_KEYS)}; "
                            f"allowed keys: {', '.join(TOP_LEVEL_KEYS)}")
    description = document.get("description", "")
    if not isinstance(description, str):
        problems.append(f"{source}: description must be a string, got {description!r}")
    matrix = document.get("matrix")
    if matrix is not None and not (isinstance(matrix, str) and matrix):
        problems.append(f"{source}: matrix must be a matrix name or path, got {matrix!r}")
    tables = document.get("bound", [])
    if not isinstance(tables, list) or not all(isinstance(table, dict) for table in tables):
        problems.append(f"{source}: bound must be an array of tables ([[bound]] sections), got {tables!r}")
        tables = []
    elif not tables:
        problems.append(f"{source}: no bounds: add [[bound]] sections")
    bounds = []
    for number, table in enumerate(tables, start=1):
        where = f"{source}: bound #{number}"
        own: list[str] = []
        bound = _parse_bound(number, table, lambda message, where=where: own.append(f"{where}: {message}"))
        problems += own
        if not own:
            bounds.append(bound)
    if problems:
        raise InputError(problems)
    return Thresholds(description=description, matrix=matrix, bounds=tuple(bounds), source=source,
                      directory=directory)


def _parse_bound(number: int, table: dict[str, Any], problem) -> Bound | None:
    for key in table:
        if key not in BOUND_KEYS:
            problem(f"unknown key {key!r}{_suggestion(key, BOUND_KEYS)}; allowed keys: {', '.join(BOUND_KEYS)}")
    scenes = _names(table, "scene", problem)
    if "scene" not in table:
        problem("scene: missing (a scene name or a list of names)")
    integrators = _names(table, "integrator", problem)
    family = table.get("family")
    if ("integrator" in table) == ("family" in table):
        problem("give exactly one of integrator (a name or a list) and family")
    if family is not None and not (isinstance(family, str) and family):
        problem(f"family must be a name, got {family!r}")
    kh = _settings(table, "kh", problem)
    tol = _settings(table, "tol", problem)
    kh_min = _number(table, "kh_min", problem, positive=True)
    kh_max = _number(table, "kh_max", problem, positive=True)
    forms = [form for form, keys in (("kh", ("kh",)), ("tol", ("tol",)), ("kh_min/kh_max", ("kh_min", "kh_max")))
             if any(key in table for key in keys)]
    if len(forms) > 1:
        problem(f"give one setting form, not {' and '.join(forms)}")
    if kh_min is not None and kh_max is not None and kh_min > kh_max:
        problem(f"kh_min = {kh_min:g} is above kh_max = {kh_max:g}")

    kinds = [kind for kind in BOUND_KINDS if kind in table]
    if len(kinds) != 1:
        problem(f"give exactly one kind of bound ({', '.join(BOUND_KINDS)}), got {', '.join(kinds) or 'none'}")
        return None
    kind = kinds[0]
    column = table.get("column")
    limit = _limit(kind, table, problem)
    _check_column(kind, column, problem)
    if kind == "min_order" and tol:
        problem("min_order is fitted across fixed-step settings (kh), not tolerances")
    relative_to = _counterpart(kind, table.get("relative_to"), problem)
    basis = table.get("basis", "")
    if not isinstance(basis, str):
        problem(f"basis must be a string (where the number comes from), got {basis!r}")
    return Bound(
        number=number,
        selection=Selection(scenes=tuple(scenes), integrators=tuple(integrators), family=family, kh=tuple(kh),
                            tol=tuple(tol), kh_min=kh_min, kh_max=kh_max),
        kind=kind,
        limit=limit,
        column=column,
        relative_to=relative_to,
        basis=basis if isinstance(basis, str) else "",
    )


def _names(table: dict[str, Any], key: str, problem) -> list[str]:
    value = table.get(key, [])
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not all(isinstance(item, str) and item for item in items) or \
            (key in table and not items):
        problem(f"{key} must be a name or a non-empty list of names, got {value!r}")
        return []
    return list(dict.fromkeys(items))


def _is_number(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def _number(table: dict[str, Any], key: str, problem, *, positive: bool = False) -> float | None:
    if key not in table:
        return None
    value = table[key]
    if not _is_number(value) or (positive and value <= 0):
        problem(f"{key} must be a finite number{' > 0' if positive else ''}, got {value!r}")
        return None
    return float(value)


def _settings(table: dict[str, Any], key: str, problem) -> list[float]:
    if key not in table:
        return []
    value = table[key]
    items = value if isinstance(value, list) else [value]
    valid = (lambda item: item > 0) if key == "kh" else (lambda item: 0 < item < 1)
    if not items or not all(_is_number(item) and valid(item) for item in items):
        wanted = "> 0 (kh = k·h)" if key == "kh" else "in (0, 1)"
        problem(f"{key} must be a number {wanted} or a non-empty list of them, got {value!r}")
        return []
    return [float(item) for item in items]


def _limit(kind: str, table: dict[str, Any], problem) -> float | str:
    value = table[kind]
    if kind == "status":
        if value not in STATUSES:
            problem(f"status must be one of {', '.join(STATUSES)}, got {value!r}")
        return str(value)
    if not _is_number(value):
        problem(f"{kind} must be a finite number, got {value!r}")
        return math.nan
    if kind in ("max_abs", "min_order", "max_ratio") and value <= 0:
        problem(f"{kind} must be > 0, got {value!r}")
    return float(value)


def _check_column(kind: str, column: Any, problem) -> None:
    if kind == "status":
        if column is not None:
            problem("a status bound takes no column")
        return
    if column is None:
        problem(f"{kind}: missing column (one of the results columns, bench.schema)")
        return
    allowed = {"min_order": ERROR_COLUMNS, "max_ratio": RATIO_COLUMNS}.get(kind, VALUE_COLUMNS)
    if column in allowed:
        return
    if column in MACHINE_COLUMNS:
        problem(f"column {column!r} depends on the machine and its load: bound it only as max_ratio to another "
                "integrator measured in the same run (relative_to)")
    elif column in COLUMN_NAMES:
        problem(f"column {column!r} cannot take a {kind} bound; columns it can: {', '.join(allowed)}")
    else:
        problem(f"unknown column {column!r}{_suggestion(column, COLUMN_NAMES)}; "
                f"columns a {kind} bound can take: {', '.join(allowed)}")


def _counterpart(kind: str, value: Any, problem) -> Counterpart | None:
    if kind != "max_ratio":
        if value is not None:
            problem("relative_to belongs to max_ratio bounds only")
        return None
    if isinstance(value, str) and value:
        return Counterpart(value)
    if isinstance(value, dict) and isinstance(value.get("integrator"), str):
        extra = set(value) - {"integrator", "kh", "tol"}
        if extra or ("kh" in value and "tol" in value):
            problem(f"relative_to takes integrator and one of kh or tol, got {value!r}")
            return None
        kh, tol = _settings(value, "kh", problem), _settings(value, "tol", problem)
        if len(kh) > 1 or len(tol) > 1:
            problem(f"relative_to takes a single setting, got {value!r}")
            return None
        return Counterpart(value["integrator"], kh[0] if kh else None, tol[0] if tol else None)
    problem(f"max_ratio needs relative_to = \"INTEGRATOR\" or {{integrator = ..., kh = ...}}, got {value!r}")
    return None


def _suggestion(word: str, choices: Iterable[Any]) -> str:
    close = difflib.get_close_matches(str(word), [str(choice) for choice in choices], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


# --- selecting rows -----------------------------------------------------------------------------------------------


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=SETTING_RELATIVE_TOLERANCE, abs_tol=0.0)


def effective_kh(row: pd.Series, requested_kh: float) -> float | None:
    """The kh the fixed-step loop runs when asked for ``requested_kh`` on the row's output grid
    (``integrators.fixed_step.uniform_output_stride``), or ``None`` when the row lacks the grid or the step."""
    from foucault_bench.integrators.fixed_step import uniform_output_stride

    n_out, duration, kh, step = (row.get(name) for name in ("n_out", "duration_s", "kh", "step_s"))
    if any(value is None or pd.isna(value) for value in (n_out, duration, kh, step)) or n_out < 2 or step <= 0:
        return None
    frequency = kh / step  # k in rad/s
    spacing = duration / (n_out - 1)
    _, step_run = uniform_output_stride(np.array([0.0, spacing]), requested_kh / frequency)
    return step_run * frequency


def _kh_matches(row: pd.Series, requested: float) -> bool:
    if pd.isna(row["kh"]):
        return False
    if _close(row["kh"], requested):
        return True
    effective = effective_kh(row, requested)
    return effective is not None and _close(row["kh"], effective)


def _setting_matches(row: pd.Series, kh: Sequence[float], tol: Sequence[float], kh_min: float | None,
                     kh_max: float | None) -> bool:
    if kh:
        return any(_kh_matches(row, value) for value in kh)
    if tol:
        return pd.notna(row["tol"]) and any(_close(row["tol"], value) for value in tol)
    if kh_min is not None or kh_max is not None:
        return pd.notna(row["kh"]) and (kh_min is None or row["kh"] >= kh_min) and \
            (kh_max is None or row["kh"] <= kh_max)
    return True


def select_rows(frame: pd.DataFrame, selection: Selection) -> pd.DataFrame:
    """The rows of ``frame`` (results-table columns) that ``selection`` picks, in frame order."""
    chosen = frame["scene"].isin(selection.scenes)
    if selection.family is not None:
        chosen &= frame["family"] == selection.family
    else:
        chosen &= frame["integrator"].isin(selection.integrators)
    candidates = frame[chosen]
    keep = [_setting_matches(row, selection.kh, selection.tol, selection.kh_min, selection.kh_max)
            for _, row in candidates.iterrows()]
    return candidates[np.array(keep, dtype=bool)] if len(candidates) else candidates


def counterpart_row(frame: pd.DataFrame, row: pd.Series, counterpart: Counterpart) -> pd.Series | None:
    """The row a ``max_ratio`` bound divides by: same scene, the other integrator, the row's or a fixed setting."""
    same = frame[(frame["scene"] == row["scene"]) & (frame["integrator"] == counterpart.integrator)]
    fixed = counterpart.kh is not None or counterpart.tol is not None
    kh, tol = (counterpart.kh, counterpart.tol) if fixed else (_float(row["kh"]), _float(row["tol"]))
    kh, tol = ((kh,) if pd.notna(kh) else ()), ((tol,) if pd.notna(tol) else ())
    found = [other for _, other in same.iterrows() if _setting_matches(other, kh, tol, None, None)]
    return found[0] if found else None


def validate_against(thresholds: Thresholds, frame: pd.DataFrame, *, what: str) -> None:
    """Raise ``InputError`` for every bound that names an unknown scene, integrator or family, or selects no row
    of ``frame`` (``what`` names the rows in messages, e.g. "matrix 'quick'"), or whose sweep or counterpart
    is missing."""
    from foucault_bench.bench.problems.scenes import SCENES
    from foucault_bench.integrators import REGISTRY

    scenes = sorted(set(frame["scene"]))
    integrators = sorted(set(frame["integrator"]))
    known_scenes = set(SCENES) | set(scenes)
    known_integrators = set(REGISTRY) | set(integrators)
    known_families = {integrator.family for integrator in REGISTRY.values()} | set(frame["family"].dropna())
    problems = []
    for bound in thresholds.bounds:
        where = f"{thresholds.source}: bound #{bound.number} ({bound.label})"
        own = []
        for scene in bound.selection.scenes:
            if scene not in known_scenes:
                own.append(f"{where}: unknown scene {scene!r}{_suggestion(scene, known_scenes)}")
            elif scene not in scenes:
                own.append(f"{where}: scene {scene!r} has no rows in {what} (its scenes: {', '.join(scenes)})")
        names = list(bound.selection.integrators)
        if bound.relative_to is not None:
            names.append(bound.relative_to.integrator)
        for name in names:
            if name not in known_integrators:
                own.append(f"{where}: unknown integrator {name!r}{_suggestion(name, known_integrators)}; "
                           f"known integrators: {', '.join(sorted(known_integrators))}")
            elif name not in integrators:
                own.append(f"{where}: integrator {name!r} has no rows in {what} "
                           f"(its integrators: {', '.join(integrators)})")
        family = bound.selection.family
        if family is not None and family not in known_families:
            own.append(f"{where}: unknown family {family!r}{_suggestion(family, known_families)}; "
                       f"known families: {', '.join(sorted(known_families))}")
        if own:
            problems += own
            continue
        rows = select_rows(frame, bound.selection)
        if rows.empty:
            settings = sorted({setting_label(row["kh"], row["tol"]) for _, row in frame[
                frame["scene"].isin(bound.selection.scenes)].iterrows()})
            problems.append(f"{where}: matches no row of {what} (settings there: {', '.join(settings)})")
        elif bound.kind == "min_order":
            problems += _sweep_problems(rows, where)
        elif bound.kind == "max_ratio":
            missing = sorted({f"{row['scene']} {setting_label(row['kh'], row['tol'])}" for _, row in rows.iterrows()
                              if counterpart_row(frame, row, bound.relative_to) is None})
            if missing:
                problems.append(f"{where}: {bound.relative_to.integrator} has no row to compare with at "
                                f"{', '.join(missing)} in {what}")
    if problems:
        raise InputError(problems)


def _sweep_problems(rows: pd.DataFrame, where: str) -> list[str]:
    problems = []
    for (scene, integrator), group in rows.groupby(["scene", "integrator"], sort=False):
        if group["kh"].isna().any():
            problems.append(f"{where}: {integrator} is adaptive; an order is fitted across fixed-step settings only")
        elif len(group) < MIN_ORDER_SETTINGS:
            problems.append(f"{where}: {scene} {integrator}: an order needs a sweep of at least "
                            f"{MIN_ORDER_SETTINGS} step sizes, the rows hold {len(group)}")
    return problems


# --- evaluating -------------------------------------------------------------------------------------------------


def headroom(kind: str, measured: float, limit: float) -> tuple[float, bool]:
    """The margin of the module docstring and whether it is a factor (both numbers positive) rather than a
    difference."""
    upper = kind in UPPER_BOUNDS
    if measured > 0 and limit > 0:
        return (limit / measured if upper else measured / limit), True
    return (limit - measured if upper else measured - limit), False


def _holds(kind: str, measured: float, limit: float) -> bool:
    return measured <= limit if kind in UPPER_BOUNDS else measured >= limit


def _not_ok(row: pd.Series) -> str:
    message = row["message"] if isinstance(row["message"], str) and row["message"] else "no message"
    return f"run {row['status']}: {message}"


def evaluate(thresholds: Thresholds, frame: pd.DataFrame) -> list[Outcome]:
    """Check every bound on ``frame`` (the results table of one matrix run, already validated with
    ``validate_against``); one outcome per bound and row (per scene × integrator for ``min_order``)."""
    from foucault_bench.bench.verdicts.convergence import observed_order

    outcomes = []
    for bound in thresholds.bounds:
        rows = select_rows(frame, bound.selection)
        if bound.kind == "min_order":
            for (scene, integrator), group in rows.groupby(["scene", "integrator"], sort=False):
                order = observed_order(group["step_s"].to_numpy(dtype=float),
                                       group[bound.column].to_numpy(dtype=float))
                settings = f"kh={group['kh'].min():.4g}..{group['kh'].max():.4g} ({len(group)} steps)"
                not_ok = group[group["status"] != "ok"]
                detail = f"{len(not_ok)} of the runs not ok (left out of the fit)" if len(not_ok) else ""
                outcomes.append(_numeric_outcome(bound, scene, integrator, settings, order, detail))
            continue
        for _, row in rows.iterrows():
            setting = setting_label(row["kh"], row["tol"])
            if bound.kind == "status":
                passed = row["status"] == bound.limit
                outcomes.append(Outcome(bound, row["scene"], row["integrator"], setting, row["status"], None, passed,
                                        "" if passed or row["status"] == "ok" else _not_ok(row)))
                continue
            if row["status"] != "ok":
                outcomes.append(Outcome(bound, row["scene"], row["integrator"], setting, f"({row['status']})", None,
                                        False, _not_ok(row)))
                continue
            value = _float(row[bound.column])
            detail = ""
            if bound.kind == "max_abs":
                value = abs(value)
            elif bound.kind == "max_ratio":
                other = counterpart_row(frame, row, bound.relative_to)
                other_value = _float(other[bound.column])
                detail = (f"{bound.relative_to.integrator} {setting_label(other['kh'], other['tol'])}: "
                          f"{other_value:.3g}")
                if other["status"] != "ok":
                    value, detail = math.nan, f"{bound.relative_to.integrator}'s {_not_ok(other)}"
                else:
                    value = value / other_value if other_value > 0 else math.nan
            outcomes.append(_numeric_outcome(bound, row["scene"], row["integrator"], setting, value, detail))
    return outcomes


def _float(value: Any) -> float:
    return math.nan if value is None or pd.isna(value) else float(value)


def _numeric_outcome(bound: Bound, scene: str, integrator: str, setting: str, value: float,
                     detail: str) -> Outcome:
    if not math.isfinite(value):
        detail = "; ".join(filter(None, [detail, "no finite value measured"]))
        return Outcome(bound, scene, integrator, setting, value, None, False, detail)
    margin, is_factor = headroom(bound.kind, value, bound.limit)
    return Outcome(bound, scene, integrator, setting, value, margin, _holds(bound.kind, value, bound.limit), detail,
                   is_factor)


# --- reporting ----------------------------------------------------------------------------------------------------


def _format_number(value: float | str | None) -> str:
    if value is None:
        return "–"
    if isinstance(value, str):
        return value
    if not math.isfinite(value):
        return "nan"
    return str(int(value)) if value.is_integer() and abs(value) < 1e9 else f"{value:.3g}"


def _format_margin(outcome: Outcome) -> str:
    if outcome.margin is None:
        return "–"
    return f"x{outcome.margin:.3g}" if outcome.margin_is_factor else f"{outcome.margin:+.3g}"


def render(outcomes: Sequence[Outcome], *, markdown: bool) -> str:
    """The table of every checked line, a summary line, and one line per failure with its basis."""
    from tabulate import tabulate

    header = ["#", "scene", "integrator", "setting", "bound", "measured", "margin", "result"]
    lines = [[outcome.bound.number, outcome.scene, outcome.integrator, outcome.setting, outcome.bound.label,
              _format_number(outcome.measured), _format_margin(outcome), "pass" if outcome.passed else "FAIL"]
             for outcome in outcomes]
    table = tabulate(lines, headers=header, tablefmt="github" if markdown else "simple", disable_numparse=True)
    failures = [outcome for outcome in outcomes if not outcome.passed]
    bounds = len({outcome.bound.number for outcome in outcomes})
    summary = (f"{bounds} bounds, {len(outcomes)} checks: {len(outcomes) - len(failures)} passed, "
               f"{len(failures)} failed")
    text = [table, "", f"**{summary}**" if markdown else summary]
    if failures:
        text += ["", "Failed:" if not markdown else "Failed bounds:"]
        text += [("- " if markdown else "  ") + failure_line(outcome) for outcome in failures]
    return "\n".join(text)


def failure_line(outcome: Outcome) -> str:
    """One failed check in words: where, what, how much, and why the bound is what it is."""
    parts = [f"bound #{outcome.bound.number} {outcome.scene} {outcome.integrator} {outcome.setting}: "
             f"{outcome.bound.label} violated, measured {_format_number(outcome.measured)}"]
    if outcome.detail:
        parts.append(f"({outcome.detail})")
    if outcome.bound.basis:
        parts.append(f"[basis: {outcome.bound.basis}]")
    return " ".join(parts)


def junit_xml(outcomes: Sequence[Outcome], *, suite: str) -> ElementTree.ElementTree:
    """JUnit XML (the de-facto schema read by CI systems: testsuites/testsuite/testcase/failure), one test case
    per checked line."""
    failures = sum(not outcome.passed for outcome in outcomes)
    suites = ElementTree.Element("testsuites", name="foucault-bench check", tests=str(len(outcomes)),
                                 failures=str(failures), errors="0")
    testsuite = ElementTree.SubElement(suites, "testsuite", name=suite, tests=str(len(outcomes)),
                                       failures=str(failures), errors="0", skipped="0")
    for outcome in outcomes:
        case = ElementTree.SubElement(
            testsuite, "testcase", classname=f"check.{outcome.scene}.{outcome.integrator}",
            name=f"#{outcome.bound.number} {outcome.setting} {outcome.bound.label}")
        measured = (f"measured {_format_number(outcome.measured)}, bound {outcome.bound.label}, "
                    f"margin {_format_margin(outcome)}")
        if not outcome.passed:
            failure = ElementTree.SubElement(case, "failure", message=failure_line(outcome), type="BoundViolated")
            failure.text = measured
        ElementTree.SubElement(case, "system-out").text = "; ".join(
            filter(None, [measured, outcome.detail, outcome.bound.basis and f"basis: {outcome.bound.basis}"]))
    ElementTree.indent(suites)
    return ElementTree.ElementTree(suites)


# --- the command --------------------------------------------------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--thresholds", required=True, metavar="FILE",
                        help="thresholds TOML file, or a built-in name (default)")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--results", metavar="DB", help="check the rows of a stored matrix run in this database")
    source.add_argument("--matrix", metavar="FILE",
                        help="run this matrix (built-in name or TOML file) and check it (default: the matrix "
                             "named in the thresholds file)")
    parser.add_argument("--matrix-id", metavar="ID",
                        help="with --results: the stored matrix run to check (id or unique prefix; default: latest)")
    parser.add_argument("--db", metavar="FILE",
                        help="when running a matrix: keep its results in this database (default: a temporary one)")
    parser.add_argument("--jobs", type=int, default=None, help="worker processes when running a matrix "
                                                               "(default: the cores available)")
    parser.add_argument("--format", choices=("text", "markdown"), default="text",
                        help="table format on stdout (markdown for CI job summaries; default: %(default)s)")
    parser.add_argument("--junit", metavar="FILE", help="also write the checks as JUnit XML")
    parser.add_argument("--run-timeout", type=float, metavar="SECONDS",
                        help="per-run time limit when running a matrix (default: the matrix's [timing] "
                             "run_timeout_s, else 600 s)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars while running a matrix")


def main(args: argparse.Namespace) -> int:
    from foucault_bench.bench.commands.outputs import creatable, output_file

    if args.junit:
        output_file(args.junit, "--junit")
    if args.db:
        creatable(args.db, "--db", folder=False)
    if args.run_timeout is not None and args.results:
        raise InputError("--run-timeout applies to a matrix run: not with --results")
    thresholds = load_thresholds(args.thresholds)
    if args.matrix_id and not args.results:
        raise InputError("--matrix-id selects a stored run: give it with --results")
    if args.db and args.results:
        raise InputError("--db is where a fresh matrix run is kept; with --results give the database there")
    if args.results:
        from foucault_bench.bench.run.store import ResultsStore

        with ResultsStore(args.results, create=False) as store:
            matrix_id = store.resolve_matrix_id(args.matrix_id)
            frame = store.frame(matrix_id)
        what = f"matrix run {matrix_id} in {args.results}"
    else:
        matrix_name = args.matrix or thresholds.matrix_to_run()
        if matrix_name is None:
            raise InputError(f"{thresholds.source} names no matrix: give --results DB or --matrix FILE")
        frame, what = run_for_check(thresholds, matrix_name, db=args.db, jobs=args.jobs,
                                    progress=not args.no_progress, run_timeout_s=args.run_timeout)
    validate_against(thresholds, frame, what=what)
    outcomes = evaluate(thresholds, frame)
    print(f"checking {thresholds.source} against {what}", file=sys.stderr)
    print(render(outcomes, markdown=args.format == "markdown"))
    if args.junit:
        junit_xml(outcomes, suite=f"{thresholds.source} on {what}").write(args.junit, encoding="utf-8",
                                                                        xml_declaration=True)
    return 0 if all(outcome.passed for outcome in outcomes) else 1


def run_for_check(thresholds: Thresholds, matrix_name: str, *, db: str | None, jobs: int | None,
                  progress: bool, run_timeout_s: float | None = None) -> tuple[pd.DataFrame, str]:
    """Validate ``thresholds`` against the planned runs of the matrix (before anything runs), run the matrix
    into ``db`` (a temporary database when ``None``) and return its rows and a description of them."""
    from foucault_bench.bench.commands.run import jobs_to_use
    from foucault_bench.bench.run.matrix import load_matrix, with_run_timeout
    from foucault_bench.bench.run.runner import run_matrix
    from foucault_bench.bench.run.store import ResultsStore

    matrix = with_run_timeout(load_matrix(matrix_name), run_timeout_s)
    jobs = jobs_to_use(jobs)
    validate_against(thresholds, planned_rows(matrix), what=f"matrix {matrix.name!r}")
    with tempfile.TemporaryDirectory(prefix="foucault-check-") as scratch:
        path = db or str(Path(scratch) / "check.sqlite")
        with ResultsStore(path) as store:
            matrix_id = run_matrix(matrix, store, jobs=jobs, progress=progress)
            frame = store.frame(matrix_id)
    return frame, f"matrix {matrix.name!r} (run {matrix_id}{f' in {db}' if db else ''})"


def planned_rows(matrix: "Matrix") -> pd.DataFrame:
    """The identity columns of the rows ``matrix`` will produce, as the runner fills them (``base_row``), with
    each fixed-step run's effective step (``uniform_output_stride`` on the scene's grid), its family and
    ``n_out``: enough to validate a thresholds file before anything runs."""
    from foucault_bench.bench.run.runner import base_row
    from foucault_bench.integrators import REGISTRY
    from foucault_bench.integrators.fixed_step import uniform_output_stride

    rows = []
    for spec in matrix.runs:
        row = base_row(spec, "planned")
        grid = spec.scene.output_grid()
        row.update(family=REGISTRY[spec.integrator].family, n_out=grid.size)
        if spec.step_s is not None:
            _, row["step_s"] = uniform_output_stride(grid, spec.step_s)
            row["kh"] = row["step_s"] * spec.scene.params.pendulum_frequency_rad_s
        rows.append(row)
    return pd.DataFrame(rows)
