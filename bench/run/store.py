"""The results store: one SQLite file (stdlib ``sqlite3``) holding every run row, its provenance and study tables.

Tables:

* ``runs``: one row per run, columns exactly ``bench.schema.COLUMNS``; primary key (matrix_id, run_key).
  The runner writes and commits each row as soon as its run finishes, so a killed matrix keeps what finished.
* ``matrix_runs``: one row per matrix run with its provenance (matrix name, source and hash, code version, git
  commit, package versions, CPU model, host, UTC start and end, jobs or scheduler, status).
* ``adequacy``: the model-adequacy rows of ``bench.problems.adequacy.model_adequacy`` per matrix run and scene.
* any study table another module writes with ``write_table`` (read back with ``read_table``).

The database records the results schema version (``bench.schema.SCHEMA_VERSION``) as SQLite's
``PRAGMA user_version``. Opening a database of an older version adds the columns it lacks (NULL, i.e. unknown,
in its old rows; ``bench.schema.MIGRATIONS``); a newer version, or tables with columns the schema does not
define, is refused with one message (``InputError``), so old rows are never misread.

Also the two standard views of stored rows: ``summarize`` (one line per scene × integrator) and
``compare_runs`` (accuracy columns bit for bit, cost as ratios).

SQLite stores a NaN as NULL (SQLite docs, "Datatypes": there is no NaN REAL value); read back, both are NaN.
"""

from __future__ import annotations

import json
import re
import sqlite3
import uuid
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.run.lock import MatrixRunLock, MatrixRunLocked
from foucault_bench.bench.schema import (
    COLUMN_NAMES, COLUMNS, MIGRATIONS, RUN_STATUSES, SCHEMA_VERSION, VERDICT_COLUMNS, is_present, setting_label,
)

if TYPE_CHECKING:  # pandas is imported by the methods that build frames, not at start-up
    import pandas as pd


    from foucault_bench.bench.run.matrix import Matrix

DEFAULT_DB = Path("results") / "foucault.sqlite"
RUNS_TABLE = "runs"
MATRIX_RUNS_TABLE = "matrix_runs"
ADEQUACY_TABLE = "adequacy"
RESERVED_TABLES = (RUNS_TABLE, MATRIX_RUNS_TABLE, ADEQUACY_TABLE)

DETERMINISTIC_COLUMNS: tuple[str, ...] = (
    "status", "n_out", "step_s", "kh", "tol", "precession_rate_rad_s", *VERDICT_COLUMNS,
    "nfev", "njev", "steps", "rejected_steps",
)
"""Columns that must be identical bit for bit when the same matrix runs twice on the same machine."""

COST_COLUMNS: tuple[str, ...] = ("cpu_time_s", "wall_time_s", "compile_time_s", "peak_rss_mb")

MATRIX_RUN_COLUMNS: tuple[tuple[str, str], ...] = (
    ("matrix_id", "TEXT PRIMARY KEY"),
    ("matrix_name", "TEXT"),
    ("matrix_source", "TEXT"),
    ("matrix_hash", "TEXT"),
    ("description", "TEXT"),
    ("runs_planned", "INTEGER"),
    ("status", "TEXT"),  # running / finished / interrupted
    ("started_utc", "TEXT"),
    ("finished_utc", "TEXT"),
    ("resumed_utc", "TEXT"),  # JSON list of the UTC times the matrix run was resumed
    ("jobs", "INTEGER"),
    ("scheduler", "TEXT"),
    ("code_version", "TEXT"),
    ("git_commit", "TEXT"),
    ("host", "TEXT"),
    ("cpu_model", "TEXT"),
    ("cpu_count", "INTEGER"),
    ("platform", "TEXT"),
    ("python", "TEXT"),
    ("package_versions", "TEXT"),  # JSON object: package → version
)

_TABLE_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def utc_now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _plain(value: Any) -> Any:
    """A value sqlite3 can bind: numpy scalars become Python numbers (``item()``), NaN stays a float (stored
    as NULL)."""
    return value.item() if hasattr(value, "item") and hasattr(value, "dtype") else value


class ResultsStore:
    """One results database. Use as a context manager or call ``close``.

    Args:
        path: the SQLite file; its directory is created when ``create`` is true.
        create: create the file and tables if missing (and use SQLite's write-ahead log). When false the file
            must exist and be a foucault-bench results database (its ``runs`` and ``matrix_runs`` tables, a
            schema version this code reads), else ``InputError``; it is opened read-only (SQLite URI
            ``mode=ro``) and nothing in it changes, except a migration from an older schema version and
            ``write_table`` (a second, writing connection opened on first use).
    """

    def __init__(self, path: str | Path = DEFAULT_DB, *, create: bool = True):
        self.path = Path(path)
        self.read_only = not create
        self.locks: dict[str, MatrixRunLock] = {}
        self._writer: sqlite3.Connection | None = None
        if not create:
            self.connection = self._open_existing()
            return
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise InputError(f"--db {self.path}: cannot create its folder: {error.strerror or error}") from None
        if self.path.exists() and not self.path.is_file():
            raise InputError(f"--db {self.path}: exists and is not a file")
        try:
            self.connection = sqlite3.connect(self.path, timeout=30.0)
            if not self._is_results_database() and self._tables():
                self.connection.close()
                raise InputError(f"{self.path}: an SQLite database of something else (tables "
                                 f"{', '.join(sorted(self._tables())[:5])}); give another --db")
            self.connection.execute("PRAGMA journal_mode=WAL")
            self._create_tables()
        except sqlite3.DatabaseError as error:
            raise InputError(f"{self.path}: not a usable SQLite results database: {error}") from None

    def _open_existing(self) -> sqlite3.Connection:
        """A read-only connection to an existing results database (see the class docstring)."""
        if not self.path.is_file():
            raise InputError(f"no results database at {self.path} (run `foucault-bench run` first, or give --db)")
        try:
            self.connection = sqlite3.connect(f"{self.path.resolve().as_uri()}?mode=ro", uri=True, timeout=30.0)
            version = self.schema_version
            if version > SCHEMA_VERSION:
                self.connection.close()
                raise InputError(f"{self.path}: written with results schema version {version}, newer than this "
                                 f"foucault-bench reads ({SCHEMA_VERSION}): upgrade foucault-bench")
            if not self._is_results_database():
                self.connection.close()
                raise InputError(f"{self.path}: not a foucault-bench results database (no {RUNS_TABLE} and "
                                 f"{MATRIX_RUNS_TABLE} tables); nothing was changed")
            if version < SCHEMA_VERSION:  # a results database of an older version: migrated, then read
                self.connection.close()
                ResultsStore(self.path).close()
                self.connection = sqlite3.connect(f"{self.path.resolve().as_uri()}?mode=ro", uri=True, timeout=30.0)
        except sqlite3.DatabaseError as error:
            raise InputError(f"{self.path}: not a usable SQLite results database: {error}") from None
        return self.connection

    def _tables(self) -> set[str]:
        return {row[0] for row in self.connection.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}

    def _is_results_database(self) -> bool:
        """Both tables of the suite are there with their key columns."""
        tables = self._tables()
        if not {RUNS_TABLE, MATRIX_RUNS_TABLE} <= tables:
            return False
        runs = {row[1] for row in self.connection.execute(f"PRAGMA table_info({RUNS_TABLE})")}
        matrix_runs = {row[1] for row in self.connection.execute(f"PRAGMA table_info({MATRIX_RUNS_TABLE})")}
        return {"run_key", "matrix_id", "status"} <= runs and {"matrix_id", "matrix_hash", "status"} <= matrix_runs

    def __enter__(self) -> "ResultsStore":
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        for lock in self.locks.values():
            lock.release()
        self.locks.clear()
        if self._writer is not None:
            self._writer.close()
        self.connection.close()

    def _lock(self, matrix_id: str) -> None:
        """Hold the matrix run's lock (``bench.run.lock``) until ``finish_matrix_run`` or ``close``; an
        ``InputError`` if another process holds it."""
        lock = MatrixRunLock(self.path, matrix_id)
        try:
            lock.acquire()
        except MatrixRunLocked:
            raise InputError(f"matrix run {matrix_id} in {self.path} is being written by another process "
                             "(a run or --resume of it is going on); wait for it to end") from None
        except OSError as error:
            raise InputError(f"{self.path}: cannot lock matrix run {matrix_id}: {error}") from None
        self.locks[matrix_id] = lock

    def _create_tables(self) -> None:
        """Create the tables of a new database, or check (and migrate) the schema version of an existing one."""
        version = self.connection.execute("PRAGMA user_version").fetchone()[0]
        if version > SCHEMA_VERSION:
            raise InputError(f"{self.path}: written with results schema version {version}, newer than this "
                             f"foucault-bench reads ({SCHEMA_VERSION}): upgrade foucault-bench or use another --db")
        if version < SCHEMA_VERSION and self._table_exists(RUNS_TABLE):
            self._migrate(max(version, 1))  # a database from before versioning (user_version 0) is version 1
        runs = ", ".join(f"{column.name} {column.sql_type}" for column in COLUMNS)
        matrix_runs = ", ".join(f"{name} {sql_type}" for name, sql_type in MATRIX_RUN_COLUMNS)
        with self.connection:
            self.connection.execute(
                f"CREATE TABLE IF NOT EXISTS {RUNS_TABLE} ({runs}, PRIMARY KEY (matrix_id, run_key))"
            )
            self.connection.execute(f"CREATE TABLE IF NOT EXISTS {MATRIX_RUNS_TABLE} ({matrix_runs})")
            self.connection.execute(f"PRAGMA user_version = {SCHEMA_VERSION:d}")

    def _migrate(self, version: int) -> None:
        """Bring a database of an older schema version up to ``SCHEMA_VERSION`` by adding the columns it lacks
        (``bench.schema.MIGRATIONS`` says which; their values are NULL, i.e. unknown, in the old rows). A
        database whose tables hold columns the schema does not know is refused, never misread."""
        if version not in MIGRATIONS:
            raise InputError(f"{self.path}: results schema version {version} cannot be migrated to "
                             f"{SCHEMA_VERSION}; use another --db")
        for table, wanted in ((RUNS_TABLE, [(column.name, column.sql_type) for column in COLUMNS]),
                              (MATRIX_RUNS_TABLE, [(name, sql_type.split()[0]) for name, sql_type in MATRIX_RUN_COLUMNS])):
            if not self._table_exists(table):
                continue
            stored = [row[1] for row in self.connection.execute(f"PRAGMA table_info({table})")]
            unknown = sorted(set(stored) - {name for name, _ in wanted})
            if unknown:
                raise InputError(f"{self.path}: table {table} has columns results schema version {SCHEMA_VERSION} "
                                 f"does not define ({', '.join(unknown)}): not a foucault-bench results database "
                                 "this version can read; use another --db")
            with self.connection:
                for name, sql_type in wanted:
                    if name not in stored:
                        self.connection.execute(f"ALTER TABLE {table} ADD COLUMN {name} {sql_type}")

    @property
    def schema_version(self) -> int:
        """The results schema version recorded in the database (``bench.schema.SCHEMA_VERSION``)."""
        return self.connection.execute("PRAGMA user_version").fetchone()[0]

    # --- matrix runs and provenance -------------------------------------------------------------------------

    def start_matrix_run(self, matrix: "Matrix", *, jobs: int | None, scheduler: str | None,
                         resume: bool) -> tuple[str, set[str]]:
        """Open a matrix run and return its id and the run keys already stored under it.

        With ``resume`` the latest matrix run with the same matrix hash (same runs, same code version) is
        continued, so that one matrix id ends up holding every row once; otherwise a new id is made.
        """
        from foucault_bench.bench.run.provenance import code_version, machine

        now = utc_now()
        if resume:
            found = self.connection.execute(
                f"SELECT matrix_id, resumed_utc FROM {MATRIX_RUNS_TABLE} WHERE matrix_hash = ? "
                "ORDER BY started_utc DESC, rowid DESC LIMIT 1",
                (matrix.matrix_hash,),
            ).fetchone()
            if found is not None:
                matrix_id, _ = found
                self._lock(matrix_id)
                resumed = self.connection.execute(  # read again under the lock
                    f"SELECT resumed_utc FROM {MATRIX_RUNS_TABLE} WHERE matrix_id = ?", (matrix_id,)).fetchone()[0]
                with self.connection:
                    self.connection.execute(
                        f"UPDATE {MATRIX_RUNS_TABLE} SET status = 'running', resumed_utc = ?, jobs = ?, "
                        "scheduler = ? WHERE matrix_id = ?",
                        (json.dumps([*json.loads(resumed or "[]"), now]), jobs, scheduler, matrix_id),
                    )
                return matrix_id, self.stored_run_keys(matrix_id)
        matrix_id = f"{datetime.now(timezone.utc):%Y%m%d-%H%M%S}-{uuid.uuid4().hex[:6]}"
        self._lock(matrix_id)
        record = {
            "matrix_id": matrix_id,
            "matrix_name": matrix.name,
            "matrix_source": matrix.source,
            "matrix_hash": matrix.matrix_hash,
            "description": matrix.description,
            "runs_planned": len(matrix.runs),
            "status": "running",
            "started_utc": now,
            "finished_utc": None,
            "resumed_utc": "[]",
            "jobs": jobs,
            "scheduler": scheduler,
            "code_version": code_version(matrix.plugins),
            **machine(),
        }
        self._insert(MATRIX_RUNS_TABLE, record)
        return matrix_id, set()

    def finish_matrix_run(self, matrix_id: str, status: str = "finished") -> None:
        with self.connection:
            self.connection.execute(
                f"UPDATE {MATRIX_RUNS_TABLE} SET status = ?, finished_utc = ? WHERE matrix_id = ?",
                (status, utc_now(), matrix_id),
            )
        lock = self.locks.pop(matrix_id, None)
        if lock is not None:
            lock.release()

    def matrix_runs(self) -> pd.DataFrame:
        """Every matrix run (provenance) with its row counts by status, oldest first."""
        import pandas as pd

        return pd.read_sql_query(
            f"SELECT m.*, COUNT(r.run_key) AS rows_stored, "
            "SUM(r.status = 'ok') AS ok, SUM(r.status = 'diverged') AS diverged, SUM(r.status = 'failed') AS failed, "
            "SUM(r.status = 'timeout') AS timeout "
            f"FROM {MATRIX_RUNS_TABLE} m LEFT JOIN {RUNS_TABLE} r ON r.matrix_id = m.matrix_id "
            "GROUP BY m.matrix_id ORDER BY m.started_utc, m.rowid",
            self.connection,
        )

    def resolve_matrix_id(self, text: str | None) -> str:
        """A stored matrix id from an exact id, a unique prefix, or ``None``/``"latest"`` for the latest."""
        ids = [row[0] for row in self.connection.execute(
            f"SELECT matrix_id FROM {MATRIX_RUNS_TABLE} ORDER BY started_utc, rowid")]
        if not ids:
            raise InputError(f"{self.path}: no matrix runs stored yet")
        if text in (None, "latest"):
            return ids[-1]
        matches = [matrix_id for matrix_id in ids if matrix_id.startswith(text)]
        if len(matches) != 1:
            kind = "no" if not matches else "more than one"
            raise InputError(f"{kind} stored matrix run matches {text!r}; stored: {', '.join(ids[-10:])}")
        return matches[0]

    # --- run rows ------------------------------------------------------------------------------------------

    def write_run(self, row: dict[str, Any]) -> None:
        """Insert one run row (keys ⊆ ``COLUMN_NAMES``; missing ones are NULL) and commit at once."""
        unknown = set(row) - set(COLUMN_NAMES)
        if unknown:
            raise ValueError(f"not columns of the results table: {', '.join(sorted(unknown))}")
        self._insert(RUNS_TABLE, {name: row.get(name) for name in COLUMN_NAMES})

    def stored_run_keys(self, matrix_id: str) -> set[str]:
        cursor = self.connection.execute(f"SELECT run_key FROM {RUNS_TABLE} WHERE matrix_id = ?", (matrix_id,))
        return {key for (key,) in cursor}

    def frame(self, matrix_id: str | None = None, *, all_runs: bool = False) -> pd.DataFrame:
        """Run rows as a DataFrame (columns ``COLUMN_NAMES``, insertion order): of ``matrix_id`` (an id, a
        unique prefix), of the latest matrix run when ``None``, or of every matrix run with ``all_runs``."""
        import pandas as pd

        if all_runs:
            return pd.read_sql_query(f"SELECT * FROM {RUNS_TABLE} ORDER BY rowid", self.connection)
        return pd.read_sql_query(
            f"SELECT * FROM {RUNS_TABLE} WHERE matrix_id = ? ORDER BY rowid",
            self.connection,
            params=(self.resolve_matrix_id(matrix_id),),
        )

    def records(self, matrix_id: str | None = None) -> list[dict[str, Any]]:
        """The run rows of a matrix run (as ``frame`` selects it) as plain dicts, NULL as ``None``, without
        pandas."""
        cursor = self.connection.execute(f"SELECT * FROM {RUNS_TABLE} WHERE matrix_id = ? ORDER BY rowid",
                                         (self.resolve_matrix_id(matrix_id),))
        names = [description[0] for description in cursor.description]
        return [dict(zip(names, values, strict=True)) for values in cursor]

    # --- adequacy and study tables --------------------------------------------------------------------------

    def write_adequacy(self, matrix_id: str, scene: str, rows: list[dict[str, Any]]) -> None:
        """Append model-adequacy rows of one scene, tagged with the matrix id (replacing earlier ones)."""
        if self._table_exists(ADEQUACY_TABLE):
            with self.connection:
                self.connection.execute(
                    f"DELETE FROM {ADEQUACY_TABLE} WHERE matrix_id = ? AND scene = ?", (matrix_id, scene))
        records = [{"matrix_id": matrix_id, "scene": scene, **row} for row in rows]
        self._append(ADEQUACY_TABLE, list(dict.fromkeys(key for record in records for key in record)), records)

    def adequacy(self, matrix_id: str | None = None) -> pd.DataFrame:
        import pandas as pd

        if not self._table_exists(ADEQUACY_TABLE):
            return pd.DataFrame()
        return pd.read_sql_query(f"SELECT * FROM {ADEQUACY_TABLE} WHERE matrix_id = ?", self.connection,
                                 params=(self.resolve_matrix_id(matrix_id),))

    def write_table(self, name: str, frame: pd.DataFrame, *, replace: bool = True) -> None:
        """Store a study table under ``name`` (replacing it, or appending with ``replace=False``)."""
        if not _TABLE_NAME.match(name) or name in RESERVED_TABLES:
            raise ValueError(f"bad table name {name!r}: use letters, digits and _, not one of {RESERVED_TABLES}")
        writer = self._writing_connection()
        if replace:
            with writer:
                writer.execute(f"DROP TABLE IF EXISTS {name}")
        self._append(name, [str(column) for column in frame.columns], frame.to_dict("records"), writer)

    def read_table(self, name: str) -> pd.DataFrame:
        import pandas as pd

        if not _TABLE_NAME.match(name) or not self._table_exists(name):
            tables = [row[0] for row in self.connection.execute("SELECT name FROM sqlite_master WHERE type='table'")]
            raise KeyError(f"no table {name!r} in {self.path}; tables: {', '.join(sorted(tables))}")
        return pd.read_sql_query(f"SELECT * FROM {name} ORDER BY rowid", self.connection)

    # --- helpers --------------------------------------------------------------------------------------------

    def _insert(self, table: str, record: dict[str, Any]) -> None:
        names = ", ".join(record)
        marks = ", ".join("?" for _ in record)
        with self.connection:
            self.connection.execute(f"INSERT INTO {table} ({names}) VALUES ({marks})",
                                    [_plain(value) for value in record.values()])

    def _table_exists(self, name: str) -> bool:
        return self.connection.execute(
            "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?", (name,)).fetchone() is not None

    def _writing_connection(self) -> sqlite3.Connection:
        """The connection to write with: the store's own, or for a store opened read-only a second one."""
        if not self.read_only:
            return self.connection
        if self._writer is None:
            self._writer = sqlite3.connect(self.path, timeout=30.0)
        return self._writer

    def _append(self, name: str, columns: list[str], records: Sequence[Mapping[str, Any]],
                connection: sqlite3.Connection | None = None) -> None:
        """Append ``records`` (mappings; a missing key is NULL) to table ``name``, creating the table with
        ``columns`` or adding the columns it lacks. Plain ``sqlite3``: the runner stores adequacy rows without
        importing pandas."""
        if not columns:
            return
        connection = connection or self.connection
        quoted = ", ".join(f'"{column}"' for column in columns)
        with connection:
            if self._table_exists(name):
                stored = {row[1] for row in connection.execute(f"PRAGMA table_info({name})")}
                for column in columns:
                    if column not in stored:
                        connection.execute(f'ALTER TABLE {name} ADD COLUMN "{column}"')
            else:
                connection.execute(f"CREATE TABLE {name} ({quoted})")
            connection.executemany(
                f"INSERT INTO {name} ({quoted}) VALUES ({', '.join('?' for _ in columns)})",
                [[_plain(record.get(column)) for column in columns] for record in records])


# --- views ----------------------------------------------------------------------------------------------------


def summarize(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One line per scene × integrator (sorted by both): run counts by status, the best (smallest) reference
    error among the ok runs, the setting that reached it and its cost (median CPU time of the worker thread,
    steps). ``rows`` are run rows as mappings (``ResultsStore.records``, or a frame's records); plain
    Python, so that printing a summary imports no pandas."""
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["scene"], row["integrator"]), []).append(row)
    lines = []
    for (scene, integrator), group in sorted(groups.items()):
        ok = [row for row in group if row["status"] == "ok" and is_present(row["reference_error"])]
        best = min(ok, key=lambda row: row["reference_error"]) if ok else None  # the first of equal errors
        lines.append({
            "scene": scene,
            "integrator": integrator,
            "runs": len(group),
            **{status: sum(row["status"] == status for row in group) for status in RUN_STATUSES},
            "best_reference_error": None if best is None else best["reference_error"],
            "at": None if best is None else setting_label(best["kh"], best["tol"]),
            "cpu_time_s": None if best is None else best["cpu_time_s"],
            "steps": None if best is None else best["steps"],
        })
    return lines


def summary_text(rows: Iterable[Mapping[str, Any]]) -> str:
    """``summarize`` as the table printed at the end of a matrix run and by ``foucault-bench results``."""
    from tabulate import tabulate

    lines = summarize(rows)
    if not lines:
        return "no runs stored"
    return tabulate(lines, headers="keys", floatfmt=".3g", missingval="–")


def _bits_equal(left: pd.Series, right: pd.Series) -> pd.Series:
    """Element-wise identity: floats compared by their 64-bit patterns (NaN equals NaN, −0.0 ≠ 0.0), others
    by value with missing equal to missing."""
    import pandas as pd
    import numpy as np

    if pd.api.types.is_numeric_dtype(left) and pd.api.types.is_numeric_dtype(right):
        left_bits = left.to_numpy(dtype=np.float64).view(np.int64)
        right_bits = right.to_numpy(dtype=np.float64).view(np.int64)
        both_nan = np.isnan(left.to_numpy(dtype=np.float64)) & np.isnan(right.to_numpy(dtype=np.float64))
        return pd.Series((left_bits == right_bits) | both_nan, index=left.index)
    return (left == right) | (left.isna() & right.isna())


def run_identity(frame: pd.DataFrame) -> pd.Series:
    """``scene integrator kh=…|tol=…`` per row, with the exact setting (float repr): what a run is, whatever
    the code version that produced it (run keys include the code version, so they differ across versions)."""
    import pandas as pd

    settings = [f"tol={float(tol)!r}" if pd.notna(tol) else f"kh={float(kh)!r}"
                for kh, tol in zip(frame["kh"], frame["tol"], strict=True)]
    return frame["scene"] + " " + frame["integrator"] + " " + pd.Series(settings, index=frame.index)


def compare_runs(frame_a: pd.DataFrame, frame_b: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame, list[str]]:
    """Compare two matrix runs row by row, matched on ``run_identity`` (scene, integrator, exact setting).

    Returns (mismatches, costs, unmatched): one mismatch line per differing deterministic column of a row
    (``DETERMINISTIC_COLUMNS``; must be empty for the same matrix and code on the same machine), the costs of A
    and B and their ratio B/A per row (``<cost>_a``, ``<cost>_b``, ``<cost>_ratio_b_over_a``), and the runs
    present in only one of the two. A ratio is given only where both costs are finite and positive: a compile
    time of 0 or below (nothing compiled, or a cached compile: the first call was no slower than the others)
    or a missing cost (a failed run) has no meaningful ratio, and gives NaN.
    """
    import numpy as np
    import pandas as pd

    left = frame_a.assign(run=run_identity(frame_a))
    right = frame_b.assign(run=run_identity(frame_b))
    merged = left.merge(right, on=["run", "scene", "integrator"], suffixes=("_a", "_b"), how="inner")
    unmatched = sorted(set(left["run"]) ^ set(right["run"]))
    mismatches = []
    for column in DETERMINISTIC_COLUMNS:
        equal = _bits_equal(merged[f"{column}_a"], merged[f"{column}_b"])
        mismatches += [{"run": run, "column": column, "a": a, "b": b}
                       for run, a, b in zip(merged["run"][~equal], merged[f"{column}_a"][~equal],
                                            merged[f"{column}_b"][~equal], strict=True)]
    costs = merged[["run", "scene", "integrator"]].copy()
    for column in COST_COLUMNS:
        cost_a, cost_b = merged[f"{column}_a"].astype(float), merged[f"{column}_b"].astype(float)
        comparable = np.isfinite(cost_a) & np.isfinite(cost_b) & (cost_a > 0) & (cost_b > 0)
        costs[f"{column}_a"], costs[f"{column}_b"] = cost_a, cost_b
        costs[f"{column}_ratio_b_over_a"] = (cost_b / cost_a).where(comparable)
    return pd.DataFrame(mismatches, columns=["run", "column", "a", "b"]), costs, unmatched
