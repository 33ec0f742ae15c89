"""Thresholds files: reading and validating the bounds of the CI gate (``foucault-bench check``).

A thresholds file (TOML, read with ``tomllib``) is a list of bounds. Each bound selects rows of the results table
(``bench.schema``) by scene, integrator (or family) and setting, and states what must hold for them::

    description = "what this gate protects"
    matrix = "quick"                 # run when check gets neither --results nor --matrix (a built-in name,
                                     # or a path relative to this file's folder, never to the current one)

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

Expected changes (``[[expected_change]]``, for ``check --baseline``, ``bench.gate.baseline``): accuracy columns of
the selected rows that may differ from the baseline run because a commit changed them on purpose::

    [[expected_change]]
    scene = "pantheon"
    integrator = "verlet"            # or family; kh / tol as for a bound, none = every setting
    columns = ["precession_rate_ref_error"]   # accuracy columns (bench.history.changes); none = all of them
    basis = "commit abc1234: new turning-point interpolant"   # required: why the change is expected

Setting match: the fixed-step loop shortens the requested step to fit a whole number of steps in each output
interval (``integrators.fixed_step.uniform_output_stride``), so a stored row holds the effective kh. A bound's
``kh`` matches a row whose kh equals the requested value or the effective step that value gives on the row's
own output grid (spacing = duration_s / (n_out − 1), k = kh / step_s of the row).

Every problem with a file (malformed TOML, an unknown key, kind or column, a bad number) is reported at once as
``bench.errors.InputError``; whether its scenes, integrators and settings exist in the rows to check is
``bench.gate.select.validate_against``'s job, and the margin of a checked line is ``bench.gate.evaluate``'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.schema import COLUMN_NAMES, VERDICT_COLUMNS
from foucault_bench.bench.validation import finite_number, read_toml, short_repr, suggestion

BUILT_IN_FOLDER = "thresholds"
"""Package folder of the built-in thresholds files (``bench/thresholds/NAME.toml``, package data)."""
SELECTION_KEYS = ("scene", "integrator", "family", "kh", "tol", "kh_min", "kh_max")
TOP_LEVEL_KEYS = ("description", "matrix", "bound", "expected_change")
EXPECTED_CHANGE_KEYS = (*SELECTION_KEYS, "columns", "basis")
BOUND_KINDS = ("max", "min", "max_abs", "status", "min_order", "max_ratio")
UPPER_BOUNDS = ("max", "max_abs", "max_ratio")
OTHER_KEYS = ("column", "relative_to", "basis")
BOUND_KEYS = SELECTION_KEYS + BOUND_KINDS + OTHER_KEYS
STATUSES = ("ok", "diverged", "failed")
BASELINE_KINDS = {"baseline_accuracy": "accuracy as in the baseline",
                  "baseline_cost": "cpu_time_s not above the baseline's beyond noise",
                  "paired_cost": "cpu_time_s not above the revision's, timed in turn"}
"""The checks ``check --baseline`` and ``check --cost-paired`` add (``bench.gate.baseline``,
``bench.gate.paired_cost_gate``): not written in a file, numbered after its bounds."""

ERROR_COLUMNS: tuple[str, ...] = tuple(name for name in VERDICT_COLUMNS if name != "energy_drift_per_s")
"""Non-negative error columns: the ones a convergence order can be fitted to."""
VALUE_COLUMNS: tuple[str, ...] = (*VERDICT_COLUMNS, "precession_rate_rad_s", "nfev", "njev", "steps",
                                  "rejected_steps")
"""Deterministic columns that ``max``, ``min`` and ``max_abs`` may bound."""
MACHINE_COLUMNS: tuple[str, ...] = ("cpu_time_s", "cpu_time_spread_s", "wall_time_s", "wall_time_spread_s",
                                     "compile_time_s", "peak_rss_mb")
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
        if self.kind in BASELINE_KINDS:
            return BASELINE_KINDS[self.kind]
        if self.kind == "min_order":
            return f"order of {self.column} >= {self.limit:g}"
        if self.kind == "max_ratio":
            assert self.relative_to is not None
            return f"{self.column} / {self.relative_to.integrator}'s <= {self.limit:g}"
        operator = {"max": "<=", "min": ">=", "max_abs": "<="}[self.kind]
        column = f"abs({self.column})" if self.kind == "max_abs" else self.column
        return f"{column} {operator} {self.limit:g}"


@dataclass(frozen=True)
class ExpectedChange:
    """An ``[[expected_change]]`` table: accuracy columns of the selected rows that may differ from a baseline
    (``check --baseline``) because a commit changed them on purpose; ``columns`` empty means every one."""

    number: int
    selection: Selection
    columns: tuple[str, ...]
    basis: str


@dataclass(frozen=True)
class Thresholds:
    """A validated thresholds file. ``matrix`` is the matrix it names: a built-in matrix name or a path, which
    is relative to ``directory``, the file's own folder, and to nothing else (never the current folder)."""

    description: str
    matrix: str | None
    bounds: tuple[Bound, ...]
    source: str
    directory: Path | None = None
    expected_changes: tuple["ExpectedChange", ...] = ()

    def matrix_to_run(self) -> str | None:
        """The matrix to load: a file beside the thresholds file (or at an absolute path), else a built-in
        matrix name; ``InputError`` when the file named is not there."""
        from foucault_bench.bench.run.matrix import built_in_matrices

        if self.matrix is None or self.directory is None:  # a built-in thresholds file names built-in matrices
            return self.matrix
        path = self.directory / self.matrix  # an absolute self.matrix stays itself
        if path.is_file():
            return str(path)
        if self.matrix in built_in_matrices():
            return self.matrix
        raise InputError(f"{self.source}: matrix = {short_repr(self.matrix)}: there is no file {path} (a path in a "
                         "thresholds file is relative to the file's own folder) and no built-in matrix of that name")



# --- reading a thresholds file ----------------------------------------------------------------------------------


def load_thresholds(name_or_path: str | Path) -> Thresholds:
    """Read and validate a thresholds file: a built-in name (``default``) or a path. ``InputError`` lists every
    problem found."""
    document, source, directory = read_toml(name_or_path, folder=BUILT_IN_FOLDER, kind="thresholds")
    return parse_thresholds(document, source=source, directory=directory)


def parse_thresholds(document: dict[str, Any], *, source: str = "thresholds",
                     directory: Path | None = None) -> Thresholds:
    """Validate a parsed thresholds document (module docstring); ``InputError`` with every problem."""
    problems: list[str] = []
    for key in document:
        if key not in TOP_LEVEL_KEYS:
            problems.append(f"{source}: unknown key {short_repr(key)}{suggestion(key, TOP_LEVEL_KEYS)}; "
                            f"allowed keys: {', '.join(TOP_LEVEL_KEYS)}")
    description = document.get("description", "")
    if not isinstance(description, str):
        problems.append(f"{source}: description must be a string, got {short_repr(description)}")
    matrix = document.get("matrix")
    if matrix is not None and not (isinstance(matrix, str) and matrix):
        problems.append(f"{source}: matrix must be a matrix name or path, got {short_repr(matrix)}")
    tables = document.get("bound", [])
    if not isinstance(tables, list) or not all(isinstance(table, dict) for table in tables):
        problems.append(f"{source}: bound must be an array of tables ([[bound]] sections), got {short_repr(tables)}")
        tables = []
    elif not tables:
        problems.append(f"{source}: no bounds: add [[bound]] sections")
    bounds = []
    for number, table in enumerate(tables, start=1):
        where = f"{source}: bound #{number}"
        own: list[str] = []
        bound = _parse_bound(number, table, lambda message, where=where, own=own: own.append(f"{where}: {message}"))
        problems += own
        if not own:
            bounds.append(cast(Bound, bound))  # None only with a problem reported
    changes = document.get("expected_change", [])
    if not isinstance(changes, list) or not all(isinstance(table, dict) for table in changes):
        problems.append(f"{source}: expected_change must be an array of tables ([[expected_change]] sections), "
                        f"got {short_repr(changes)}")
        changes = []
    expected = []
    for number, table in enumerate(changes, start=1):
        where = f"{source}: expected_change #{number}"
        own = []
        change = _parse_expected_change(number, table, lambda message, where=where, own=own: own.append(f"{where}: {message}"))
        problems += own
        expected.append(change)
    if problems:
        raise InputError(problems)
    return Thresholds(description=description, matrix=matrix, bounds=tuple(bounds), source=source,
                      directory=directory, expected_changes=tuple(expected))


def _parse_bound(number: int, table: dict[str, Any], problem) -> Bound | None:
    for key in table:
        if key not in BOUND_KEYS:
            problem(f"unknown key {short_repr(key)}{suggestion(key, BOUND_KEYS)}; allowed keys: {', '.join(BOUND_KEYS)}")
    selection = _parse_selection(table, problem)

    kinds = [kind for kind in BOUND_KINDS if kind in table]
    if len(kinds) != 1:
        problem(f"give exactly one kind of bound ({', '.join(BOUND_KINDS)}), got {', '.join(kinds) or 'none'}")
        return None
    kind = kinds[0]
    column = table.get("column")
    limit = _limit(kind, table, problem)
    _check_column(kind, column, problem)
    if kind == "min_order" and selection.tol:
        problem("min_order is fitted across fixed-step settings (kh), not tolerances")
    relative_to = _counterpart(kind, table.get("relative_to"), problem)
    basis = table.get("basis", "")
    if not isinstance(basis, str):
        problem(f"basis must be a string (where the number comes from), got {short_repr(basis)}")
    return Bound(
        number=number,
        selection=selection,
        kind=kind,
        limit=limit,
        column=column,
        relative_to=relative_to,
        basis=basis if isinstance(basis, str) else "",
    )


def _parse_selection(table: dict[str, Any], problem) -> Selection:
    """The rows a bound or an expected change selects (``Selection``), every problem reported."""
    scenes = _names(table, "scene", problem)
    if "scene" not in table:
        problem("scene: missing (a scene name or a list of names)")
    integrators = _names(table, "integrator", problem)
    family = table.get("family")
    if ("integrator" in table) == ("family" in table):
        problem("give exactly one of integrator (a name or a list) and family")
    if family is not None and not (isinstance(family, str) and family):
        problem(f"family must be a name, got {short_repr(family)}")
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

    return Selection(scenes=tuple(scenes), integrators=tuple(integrators), family=family, kh=tuple(kh),
                     tol=tuple(tol), kh_min=kh_min, kh_max=kh_max)


def _parse_expected_change(number: int, table: dict[str, Any], problem) -> ExpectedChange:
    from foucault_bench.bench.history.changes import ACCURACY_COLUMNS

    for key in table:
        if key not in EXPECTED_CHANGE_KEYS:
            problem(f"unknown key {short_repr(key)}{suggestion(key, EXPECTED_CHANGE_KEYS)}; allowed keys: "
                    f"{', '.join(EXPECTED_CHANGE_KEYS)}")
    selection = _parse_selection(table, problem)
    columns = _names(table, "columns", problem)
    for column in columns:
        if column not in ACCURACY_COLUMNS:
            problem(f"columns: {short_repr(column)} is not an accuracy column{suggestion(column, ACCURACY_COLUMNS)}")
    basis = table.get("basis")
    if not (isinstance(basis, str) and basis.strip()):
        problem("basis: missing (say why the change is expected, e.g. the commit and what it changed)")
    return ExpectedChange(number, selection, tuple(columns), basis if isinstance(basis, str) else "")


def _names(table: dict[str, Any], key: str, problem) -> list[str]:
    value = table.get(key, [])
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not all(isinstance(item, str) and item for item in items) or \
            (key in table and not items):
        problem(f"{key} must be a name or a non-empty list of names, got {short_repr(value)}")
        return []
    return list(dict.fromkeys(items))

def _number(table: dict[str, Any], key: str, problem, *, positive: bool = False) -> float | None:
    if key not in table:
        return None
    value = table[key]
    if not finite_number(value, positive=positive):
        problem(f"{key} must be a finite number{' > 0' if positive else ''}, got {short_repr(value)}")
        return None
    return float(value)


def _settings(table: dict[str, Any], key: str, problem) -> list[float]:
    if key not in table:
        return []
    value = table[key]
    items = value if isinstance(value, list) else [value]
    valid = (lambda item: item > 0) if key == "kh" else (lambda item: 0 < item < 1)
    if not items or not all(finite_number(item) and valid(item) for item in items):
        wanted = "> 0 (kh = k·h)" if key == "kh" else "in (0, 1)"
        problem(f"{key} must be a number {wanted} or a non-empty list of them, got {short_repr(value)}")
        return []
    return [float(item) for item in items]


def _limit(kind: str, table: dict[str, Any], problem) -> float | str:
    value = table[kind]
    if kind == "status":
        if value not in STATUSES:
            problem(f"status must be one of {', '.join(STATUSES)}, got {short_repr(value)}")
        return str(value)
    if not finite_number(value):
        problem(f"{kind} must be a finite number, got {short_repr(value)}")
        return math.nan
    if kind in ("max_abs", "min_order", "max_ratio") and value <= 0:
        problem(f"{kind} must be > 0, got {short_repr(value)}")
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
        problem(f"column {short_repr(column)} depends on the machine and its load: bound it only as max_ratio to another "
                "integrator measured in the same run (relative_to)")
    elif column in COLUMN_NAMES:
        problem(f"column {short_repr(column)} cannot take a {kind} bound; columns it can: {', '.join(allowed)}")
    else:
        problem(f"unknown column {short_repr(column)}{suggestion(column, COLUMN_NAMES)}; "
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
            problem(f"relative_to takes integrator and one of kh or tol, got {short_repr(value)}")
            return None
        kh, tol = _settings(value, "kh", problem), _settings(value, "tol", problem)
        if len(kh) > 1 or len(tol) > 1:
            problem(f"relative_to takes a single setting, got {short_repr(value)}")
            return None
        return Counterpart(value["integrator"], kh[0] if kh else None, tol[0] if tol else None)
    problem(f"max_ratio needs relative_to = \"INTEGRATOR\" or {{integrator = ..., kh = ...}}, got {short_repr(value)}")
    return None
