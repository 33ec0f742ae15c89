"""The results store: one SQLite file (stdlib ``sqlite3``) holding every run row, its provenance and study tables.

Tables:

* ``runs``: one row per run, columns exactly ``bench.schema.COLUMNS``; primary key (matrix_id, run_key).
  The runner writes and commits each row as soon as its run finishes, so a killed matrix keeps what finished.
* ``matrix_runs``: one row per matrix run with its provenance (matrix name, source and hash, code version, git
  commit, package versions, CPU model, host, UTC start and end, jobs or scheduler, status).
* ``adequacy``: the model-adequacy rows of ``bench.verdicts.adequacy.model_adequacy`` per matrix run and scene.
* any study table another module writes with ``write_table`` (read back with ``read_table``).

The database records the results schema version (``bench.schema.SCHEMA_VERSION``) as SQLite's
``PRAGMA user_version``. Opening a database of an older version adds the columns it lacks (NULL, i.e. unknown,
in its old rows; ``bench.schema.MIGRATIONS``); a newer version, or tables with columns the schema does not
define, is refused with one message (``InputError``), so old rows are never misread. The tables' columns and
that opening and migration are ``bench.run.store_schema``; the standard views of stored rows are
``bench.run.summary`` (one line per scene × integrator) and ``bench.run.compare`` (two matrix runs, accuracy
columns bit for bit, cost as ratios).

SQLite stores a NaN as NULL (SQLite docs, "Datatypes": there is no NaN REAL value); read back, both are NaN.
"""

from __future__ import annotations

import contextlib
import functools
import json
import re
import sqlite3
import uuid
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator, Mapping, Sequence, TypeVar

from foucault_bench.bench.errors import InputError, database_error_types
from foucault_bench.bench.run.lock import MatrixRunLock, MatrixRunLocked
from foucault_bench.bench.run.store_schema import (
    ADEQUACY_TABLE, DAMAGED_CODES, MATRIX_RUNS_TABLE, RESERVED_TABLES, RUNS_TABLE, check_readable,
    create_tables, read_only_connection, schema_version, select_list, table_exists,
)
from foucault_bench.bench.schema import COLUMN_NAMES, COLUMNS, SCHEMA_VERSION

if TYPE_CHECKING:  # pandas is imported by the methods that build frames, not at start-up
    import pandas as pd

    from foucault_bench.bench.run.matrix import Matrix

DEFAULT_DB = Path("results") / "foucault.sqlite"
_TABLE_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
Result = TypeVar("Result")

REAL_DTYPES = {column.name: "float64" for column in COLUMNS if column.sql_type == "REAL"}
"""The REAL columns as float64 in every frame of runs: a column whose stored values are all NULL (every run of a
scene failed or timed out) would otherwise come back as Python ``None`` objects, on which no arithmetic works."""


def utc_now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _plain(value: Any) -> Any:
    """A value sqlite3 can bind: numpy scalars become Python numbers (``item()``), NaN stays a float (stored
    as NULL)."""
    return value.item() if hasattr(value, "item") and hasattr(value, "dtype") else value


def _guarded(method: Callable[..., Result]) -> Callable[..., Result]:
    """``method`` of ``ResultsStore`` with SQLite errors as one ``InputError`` (``ResultsStore._database_errors``)."""

    @functools.wraps(method)
    def guarded(self: "ResultsStore", *args: Any, **kwargs: Any) -> Result:
        with self._database_errors():
            return method(self, *args, **kwargs)

    return guarded


class ResultsStore:
    """One results database. Use as a context manager or call ``close``.

    Args:
        path: the SQLite file; its directory is created when ``create`` is true.
        create: create the file and tables if missing (and use SQLite's write-ahead log). When false the file
            must exist and be a foucault-bench results database (its ``runs`` and ``matrix_runs`` tables, a
            schema version this code reads), else ``InputError``; it is opened read-only (``read_only_connection``)
            and nothing in it changes, its journal mode included, except a migration from an older schema
            version (where the file can be written; else it is read as it is, the columns it lacks NULL) and
            ``write_table`` (a second, writing connection opened on first use).

    Either way an existing file is first read read-only: a database this code cannot read (a newer schema
    version, another program's tables, a damaged file) is refused before anything in it changes. Any
    ``sqlite3.DatabaseError`` later (a page damaged after the header) becomes an ``InputError`` naming the file.
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
        if self.path.is_file() and self.path.stat().st_size > 0:
            self._check_readable(create=True)  # read-only: a refused database is left exactly as it was
        with self._database_errors():
            self.connection = sqlite3.connect(self.path, timeout=30.0)
            self.connection.execute("PRAGMA journal_mode=WAL")
            create_tables(self.connection, self.path)
            self._run_columns = select_list(self.connection)

    def _open_existing(self) -> sqlite3.Connection:
        """A read-only connection to an existing results database (see the class docstring)."""
        if not self.path.is_file():
            raise InputError(f"no results database at {self.path} (run `foucault-bench run` first, or give --db)")
        if self._check_readable(create=False) < SCHEMA_VERSION:  # an older version: migrated, then read
            with self._database_errors():
                writer = sqlite3.connect(self.path, timeout=30.0)  # its journal mode is kept
                try:
                    self.connection = writer
                    create_tables(self.connection, self.path)
                except sqlite3.OperationalError as error:  # a file SQLite cannot write is read as it is
                    if getattr(error, "sqlite_errorcode", 0) & 0xFF not in (sqlite3.SQLITE_READONLY,
                                                                            sqlite3.SQLITE_CANTOPEN):
                        raise
                finally:
                    writer.close()
        with self._database_errors():
            self.connection = read_only_connection(self.path)
            self._run_columns = select_list(self.connection)
        return self.connection

    def _check_readable(self, *, create: bool) -> int:
        """Refuse (``InputError``, nothing changed) an existing file this code cannot use; its schema version
        (``bench.run.store_schema.check_readable``)."""
        with self._database_errors():
            return check_readable(self.path, create=create)

    @contextlib.contextmanager
    def _database_errors(self) -> Iterator[None]:
        """Turn an SQLite error (``sqlite3.DatabaseError``, or pandas' wrapper of one) into one ``InputError``
        naming the file."""
        try:
            yield
        except database_error_types() as error:
            cause = error.__cause__ if isinstance(error.__cause__, sqlite3.DatabaseError) else error
            if not isinstance(cause, sqlite3.DatabaseError):
                raise
            code = getattr(cause, "sqlite_errorcode", 0) & 0xFF
            damaged = " (the file is damaged or not an SQLite database)" if code in DAMAGED_CODES else ""
            text = str(cause).splitlines()[0] if str(cause) else type(cause).__name__
            raise InputError(f"{self.path}: not a usable SQLite results database{damaged}: {text}") from None

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

    @property
    def schema_version(self) -> int:
        """The results schema version recorded in the database (``bench.schema.SCHEMA_VERSION``)."""
        return schema_version(self.connection)

    # --- matrix runs and provenance -------------------------------------------------------------------------

    @_guarded
    def start_matrix_run(self, matrix: "Matrix", *, jobs: int | None, scheduler: str | None,
                         resume: bool) -> tuple[str, set[str]]:
        """Open a matrix run and return its id and the run keys already stored under it.

        With ``resume`` the latest matrix run with the same matrix hash (same runs, same code version) is
        continued, so that one matrix id ends up holding every row once; otherwise a new id is made.
        """
        from foucault_bench.bench.provenance import code_version, machine

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

    @_guarded
    def finish_matrix_run(self, matrix_id: str, status: str = "finished") -> None:
        with self.connection:
            self.connection.execute(
                f"UPDATE {MATRIX_RUNS_TABLE} SET status = ?, finished_utc = ? WHERE matrix_id = ?",
                (status, utc_now(), matrix_id),
            )
        lock = self.locks.pop(matrix_id, None)
        if lock is not None:
            lock.release()

    @_guarded
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

    @_guarded
    def resolve_matrix_id(self, text: str | None) -> str:
        """A stored matrix id from an exact id, a unique prefix, or ``None``/``"latest"`` for the latest."""
        ids = [row[0] for row in self.connection.execute(
            f"SELECT matrix_id FROM {MATRIX_RUNS_TABLE} ORDER BY started_utc, rowid")]
        if not ids:
            raise InputError(f"{self.path}: no matrix runs stored yet")
        if text in (None, "latest"):
            return ids[-1]
        if text in ids:  # an exact id, even where it is also the prefix of another
            return text
        matches = [matrix_id for matrix_id in ids if matrix_id.startswith(text)]
        if len(matches) != 1:
            kind = "no" if not matches else "more than one"
            raise InputError(f"{kind} stored matrix run matches {text!r}; stored: {', '.join(ids[-10:])}")
        return matches[0]

    # --- run rows ------------------------------------------------------------------------------------------

    @_guarded
    def write_run(self, row: dict[str, Any]) -> None:
        """Insert one run row (keys ⊆ ``COLUMN_NAMES``; missing ones are NULL) and commit at once."""
        unknown = set(row) - set(COLUMN_NAMES)
        if unknown:
            raise ValueError(f"not columns of the results table: {', '.join(sorted(unknown))}")
        self._insert(RUNS_TABLE, {name: row.get(name) for name in COLUMN_NAMES})

    @_guarded
    def stored_run_keys(self, matrix_id: str) -> set[str]:
        cursor = self.connection.execute(f"SELECT run_key FROM {RUNS_TABLE} WHERE matrix_id = ?", (matrix_id,))
        return {key for (key,) in cursor}

    @_guarded
    def frame(self, matrix_id: str | None = None, *, all_runs: bool = False) -> pd.DataFrame:
        """Run rows as a DataFrame (columns ``COLUMN_NAMES``, insertion order): of ``matrix_id`` (an id, a
        unique prefix), of the latest matrix run when ``None``, or of every matrix run with ``all_runs``."""
        import pandas as pd

        if all_runs:
            return pd.read_sql_query(f"SELECT {self._run_columns} FROM {RUNS_TABLE} ORDER BY rowid", self.connection,
                                     dtype=REAL_DTYPES)
        return pd.read_sql_query(
            f"SELECT {self._run_columns} FROM {RUNS_TABLE} WHERE matrix_id = ? ORDER BY rowid",
            self.connection,
            params=(self.resolve_matrix_id(matrix_id),),
            dtype=REAL_DTYPES,
        )

    @_guarded
    def records(self, matrix_id: str | None = None) -> list[dict[str, Any]]:
        """The run rows of a matrix run (as ``frame`` selects it) as plain dicts, NULL as ``None``, without
        pandas."""
        cursor = self.connection.execute(f"SELECT {self._run_columns} FROM {RUNS_TABLE} WHERE matrix_id = ? ORDER BY rowid",
                                         (self.resolve_matrix_id(matrix_id),))
        names = [description[0] for description in cursor.description]
        return [dict(zip(names, values, strict=True)) for values in cursor]

    # --- adequacy and study tables --------------------------------------------------------------------------

    @_guarded
    def write_adequacy(self, matrix_id: str, scene: str, rows: list[dict[str, Any]], *,
                       scene_key: str | None = None) -> None:
        """Append model-adequacy rows of one scene (its name and ``bench.problems.scene_key`` key), tagged with
        the matrix id (replacing earlier ones of that scene)."""
        if table_exists(self.connection, ADEQUACY_TABLE):
            stored = {row[1] for row in self.connection.execute(f"PRAGMA table_info({ADEQUACY_TABLE})")}
            same_key = " AND scene_key IS ?" if "scene_key" in stored else ""
            with self.connection:
                self.connection.execute(f"DELETE FROM {ADEQUACY_TABLE} WHERE matrix_id = ? AND scene = ?{same_key}",
                                        (matrix_id, scene, scene_key)[:3 if same_key else 2])
        records = [{"matrix_id": matrix_id, "scene": scene, "scene_key": scene_key, **row} for row in rows]
        self._append(ADEQUACY_TABLE, list(dict.fromkeys(key for record in records for key in record)), records)

    @_guarded
    def adequacy(self, matrix_id: str | None = None) -> pd.DataFrame:
        import pandas as pd

        if not table_exists(self.connection, ADEQUACY_TABLE):
            return pd.DataFrame()
        return pd.read_sql_query(f"SELECT * FROM {ADEQUACY_TABLE} WHERE matrix_id = ?", self.connection,
                                 params=(self.resolve_matrix_id(matrix_id),))

    @_guarded
    def write_table(self, name: str, frame: pd.DataFrame, *, replace: bool = True) -> None:
        """Store a study table under ``name`` (replacing it, or appending with ``replace=False``)."""
        if not _TABLE_NAME.match(name) or name in RESERVED_TABLES:
            raise ValueError(f"bad table name {name!r}: use letters, digits and _, not one of {RESERVED_TABLES}")
        writer = self._writing_connection()
        if replace:
            with writer:
                writer.execute(f"DROP TABLE IF EXISTS {name}")
        self._append(name, [str(column) for column in frame.columns], frame.to_dict("records"), writer)

    @_guarded
    def read_table(self, name: str) -> pd.DataFrame:
        import pandas as pd

        if not _TABLE_NAME.match(name) or not table_exists(self.connection, name):
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
            if table_exists(self.connection, name):
                stored = {row[1] for row in connection.execute(f"PRAGMA table_info({name})")}
                for column in columns:
                    if column not in stored:
                        connection.execute(f'ALTER TABLE {name} ADD COLUMN "{column}"')
            else:
                connection.execute(f"CREATE TABLE {name} ({quoted})")
            connection.executemany(
                f"INSERT INTO {name} ({quoted}) VALUES ({', '.join('?' for _ in columns)})",
                [[_plain(record.get(column)) for column in columns] for record in records])
