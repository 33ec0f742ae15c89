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

import contextlib
import functools
import json
import os
import re
import sqlite3
import uuid
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator, Mapping, Sequence, TypeVar

from foucault_bench.bench.errors import InputError, database_error_types
from foucault_bench.bench.problems.scene_key import UNKNOWN_KEY_LABEL, label_map, scene_labels
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
Result = TypeVar("Result")


def utc_now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _plain(value: Any) -> Any:
    """A value sqlite3 can bind: numpy scalars become Python numbers (``item()``), NaN stays a float (stored
    as NULL)."""
    return value.item() if hasattr(value, "item") and hasattr(value, "dtype") else value


DAMAGED_CODES = (sqlite3.SQLITE_CORRUPT, sqlite3.SQLITE_NOTADB)
"""SQLite result codes of a damaged file (sqlite.org/rescode.html: SQLITE_CORRUPT "database disk image is
malformed", SQLITE_NOTADB "file is not a database")."""


def _guarded(method: Callable[..., Result]) -> Callable[..., Result]:
    """``method`` of ``ResultsStore`` with SQLite errors as one ``InputError`` (``ResultsStore._database_errors``)."""

    @functools.wraps(method)
    def guarded(self: "ResultsStore", *args: Any, **kwargs: Any) -> Result:
        with self._database_errors():
            return method(self, *args, **kwargs)

    return guarded


def read_only_connection(path: Path) -> sqlite3.Connection:
    """A read-only connection (SQLite URI ``mode=ro``) to the database ``path``, its schema version read.

    Never changes the file or its journal mode. SQLite opens a write-ahead-log (WAL) database read-only only if
    its ``-shm`` and ``-wal`` files exist or can be created, or if the database is opened as immutable
    (sqlite.org/wal.html, "Read-Only Databases", SQLite ≥ 3.22). So when SQLite cannot open the file
    (SQLITE_CANTOPEN) in a folder this process cannot write, and no ``-wal`` file holds changes (everything is
    in the main file), it is opened with ``immutable=1`` (sqlite.org/uri.html): safe there, since no writer can
    change it either (a writer needs its ``-wal`` or journal file in that folder). A ``-wal`` file holding
    changes in such a folder cannot be read without its ``-shm``: ``InputError``, with what to do. A reader of a
    WAL database in a writable folder leaves the ``-wal`` and ``-shm`` files, as every SQLite reader does; they
    are SQLite's, not a change of mode.
    """
    uri = path.resolve().as_uri()
    connection = sqlite3.connect(f"{uri}?mode=ro", uri=True, timeout=30.0)
    try:
        connection.execute("PRAGMA user_version").fetchone()
        return connection
    except sqlite3.OperationalError as error:
        connection.close()
        if getattr(error, "sqlite_errorcode", 0) & 0xFF != sqlite3.SQLITE_CANTOPEN or os.access(path.parent, os.W_OK):
            raise
    log = Path(f"{path}-wal")
    if log.exists() and log.stat().st_size > 0:
        raise InputError(f"{path}: a write-ahead-log database whose {log.name} holds changes SQLite cannot read in "
                         "a folder it cannot write; copy the database and its -wal file to a writable folder")
    connection = sqlite3.connect(f"{uri}?mode=ro&immutable=1", uri=True, timeout=30.0)
    connection.execute("PRAGMA user_version").fetchone()
    return connection


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
            self._create_tables()
            self._run_columns = self._select_list()

    def _open_existing(self) -> sqlite3.Connection:
        """A read-only connection to an existing results database (see the class docstring)."""
        if not self.path.is_file():
            raise InputError(f"no results database at {self.path} (run `foucault-bench run` first, or give --db)")
        if self._check_readable(create=False) < SCHEMA_VERSION:  # an older version: migrated, then read
            with self._database_errors():
                writer = sqlite3.connect(self.path, timeout=30.0)  # its journal mode is kept
                try:
                    self.connection = writer
                    self._create_tables()
                except sqlite3.OperationalError as error:  # a file SQLite cannot write is read as it is
                    if getattr(error, "sqlite_errorcode", 0) & 0xFF not in (sqlite3.SQLITE_READONLY,
                                                                            sqlite3.SQLITE_CANTOPEN):
                        raise
                finally:
                    writer.close()
        with self._database_errors():
            self.connection = read_only_connection(self.path)
            self._run_columns = self._select_list()
        return self.connection

    def _select_list(self) -> str:
        """The run columns in ``COLUMNS`` order, those the table lacks as NULL: a database of an older schema
        version that could not be migrated (its file or folder is read-only) is read as it is, its missing
        columns unknown; a migrated one holds its added columns last."""
        stored = {row[1] for row in self.connection.execute(f"PRAGMA table_info({RUNS_TABLE})")}
        return ", ".join(name if name in stored else f"NULL AS {name}" for name in COLUMN_NAMES)

    def _check_readable(self, *, create: bool) -> int:
        """Read the existing file's schema version and tables read-only and refuse (``InputError``, nothing
        changed) a database this code cannot use; return the version."""
        with self._database_errors():
            connection = read_only_connection(self.path)
            try:
                self.connection = connection
                version = self._stored_version = self.schema_version
                tables = self._tables()
                if version > SCHEMA_VERSION:
                    raise InputError(f"{self.path}: written with results schema version {version}, newer than "
                                     f"this foucault-bench reads ({SCHEMA_VERSION}): upgrade foucault-bench"
                                     + (" or use another --db" if create else "") + "; nothing was changed")
                if not self._is_results_database() and (tables or not create):
                    raise InputError(
                        f"{self.path}: an SQLite database of something else (tables "
                        f"{', '.join(sorted(tables)[:5])}); give another --db" if create and tables else
                        f"{self.path}: not a foucault-bench results database (no {RUNS_TABLE} and "
                        f"{MATRIX_RUNS_TABLE} tables); nothing was changed")
                if version < SCHEMA_VERSION and self._table_exists(RUNS_TABLE) and max(version, 1) not in MIGRATIONS:
                    raise InputError(f"{self.path}: results schema version {version} cannot be migrated to "
                                     f"{SCHEMA_VERSION}; use another --db")
                return version
            finally:
                connection.close()

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
        self._recover_scene_keys()

    def _recover_scene_keys(self) -> None:
        """Fill ``scene_key`` of old rows where their physics can be proved (``bench.schema.MIGRATIONS``).

        A row is proved to be of a built-in scene ``S`` (or of its variant ``S-azψ``, the release azimuth ψ
        swept by a matrix) when its run key, which hashes the scene's name and physics with the integrator,
        the setting and the code version (``bench.run.matrix.RunSpec.run_key``), is the one that scene's present
        physics gives. Within one matrix run and name, the rows then all get the one proved key if no adaptive
        row contradicts it (a fixed-step row stores the step taken, which may differ from the step its key
        hashes, so it cannot always prove its own key). Every other row keeps NULL. Idempotent: a migration
        interrupted half-way is completed by the next one."""
        import dataclasses

        from foucault_bench.bench.problems.scene_key import scene_key
        from foucault_bench.bench.problems.scenes import SCENES
        from foucault_bench.bench.run.matrix import RunSpec
        from foucault_bench.bench.run.timing import TimingPolicy

        def candidate(name: str) -> Any:
            base, _, azimuth = name.rpartition("-az")
            if name in SCENES:
                return SCENES[name]
            try:
                scene = SCENES[base]
                return dataclasses.replace(scene, name=name, params=dataclasses.replace(
                    scene.params, release_azimuth_deg=float(azimuth)))
            except (KeyError, ValueError, InputError):  # not a built-in name, or not an azimuth after -az
                return None

        rows = self.connection.execute(
            f"SELECT r.rowid, r.matrix_id, r.scene, r.run_key, r.integrator, r.kh, r.tol, m.code_version "
            f"FROM {RUNS_TABLE} r LEFT JOIN {MATRIX_RUNS_TABLE} m ON m.matrix_id = r.matrix_id "
            "WHERE r.scene_key IS NULL").fetchall()
        scenes = {name: candidate(name) for name in {row[2] for row in rows}}
        groups: dict[tuple[str, str], list[tuple[int, str | None, bool]]] = {}
        timing = TimingPolicy()
        for rowid, matrix_id, name, run_key, integrator, kh, tol, code in rows:
            scene = scenes[name]
            proved = scene is not None and code is not None and run_key == RunSpec(
                scene=scene, integrator=integrator, kh=kh, tol=tol, plugins=(), timing=timing,
                code_version=code).run_key
            groups.setdefault((matrix_id, name), []).append((rowid, scene_key(scene) if proved else None,
                                                             tol is not None))
        updates = []
        for members in groups.values():
            keys = {key for _, key, _ in members if key is not None}
            contradicted = any(key is None and adaptive for _, key, adaptive in members)
            for rowid, key, _ in members:
                known = next(iter(keys)) if len(keys) == 1 and not contradicted else key
                if known is not None:
                    updates.append((known, rowid))
        with self.connection:
            self.connection.executemany(f"UPDATE {RUNS_TABLE} SET scene_key = ? WHERE rowid = ?", updates)
            if self._table_exists(ADEQUACY_TABLE):
                stored = {row[1] for row in self.connection.execute(f"PRAGMA table_info({ADEQUACY_TABLE})")}
                if "scene_key" not in stored:
                    self.connection.execute(f"ALTER TABLE {ADEQUACY_TABLE} ADD COLUMN scene_key TEXT")
                self.connection.execute(  # the key of the runs of that matrix run and name, where they have one
                    f"UPDATE {ADEQUACY_TABLE} SET scene_key = (SELECT MIN(r.scene_key) FROM {RUNS_TABLE} r "
                    f"WHERE r.matrix_id = {ADEQUACY_TABLE}.matrix_id AND r.scene = {ADEQUACY_TABLE}.scene "
                    f"HAVING COUNT(DISTINCT r.scene_key) = 1 AND COUNT(r.scene_key) = COUNT(*)) "
                    "WHERE scene_key IS NULL")

    @property
    def schema_version(self) -> int:
        """The results schema version recorded in the database (``bench.schema.SCHEMA_VERSION``)."""
        return self.connection.execute("PRAGMA user_version").fetchone()[0]

    # --- matrix runs and provenance -------------------------------------------------------------------------

    @_guarded
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
            return pd.read_sql_query(f"SELECT {self._run_columns} FROM {RUNS_TABLE} ORDER BY rowid", self.connection)
        return pd.read_sql_query(
            f"SELECT {self._run_columns} FROM {RUNS_TABLE} WHERE matrix_id = ? ORDER BY rowid",
            self.connection,
            params=(self.resolve_matrix_id(matrix_id),),
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
        if self._table_exists(ADEQUACY_TABLE):
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

        if not self._table_exists(ADEQUACY_TABLE):
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
    steps). A scene is its name and physics (``scene_key``): a name with two physics gives two scenes, labelled
    as ``bench.problems.scene_key.scene_labels`` does. ``rows`` are run rows as mappings
    (``ResultsStore.records``, or a frame's records); plain Python, so that printing a summary imports no
    pandas."""
    rows = list(rows)
    labels = label_map((row["scene"], row.get("scene_key")) for row in rows)
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        scene = labels[str(row["scene"]), row.get("scene_key") if isinstance(row.get("scene_key"), str) else None]
        groups.setdefault((scene, row["integrator"]), []).append(row)
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


def run_identity(frame: pd.DataFrame, among: pd.DataFrame | None = None) -> pd.Series:
    """``scene integrator kh=…|tol=…`` per row, with the exact setting (float repr): what a run is, whatever
    the code version that produced it (run keys include the code version, so they differ across versions). The
    scene is its label among ``frame`` and ``among`` (``bench.problems.scene_key.scene_labels``): a name with
    two physics gives two scenes."""
    import pandas as pd

    settings = [f"tol={float(tol)!r}" if pd.notna(tol) else f"kh={float(kh)!r}"
                for kh, tol in zip(frame["kh"], frame["tol"], strict=True)]
    return scene_labels(frame, among) + " " + frame["integrator"] + " " + pd.Series(settings, index=frame.index)


def scene_differences(frame_a: pd.DataFrame, frame_b: pd.DataFrame) -> dict[str, str]:
    """Scene name → why its runs in A and B are different scenes, for every name both hold with other physics
    (``scene_key``; rows of unknown physics are a physics of their own)."""

    def keys(frame: pd.DataFrame) -> dict[str, set[str]]:
        found: dict[str, set[str]] = {}
        column = frame["scene_key"] if "scene_key" in frame.columns else [None] * len(frame)
        for name, key in zip(frame["scene"], column, strict=True):
            found.setdefault(str(name), set()).add(key if isinstance(key, str) else UNKNOWN_KEY_LABEL)
        return found

    in_a, in_b = keys(frame_a), keys(frame_b)
    return {name: f"scene {name} has other physics in A ({', '.join(sorted(in_a[name]))}) than in B "
                  f"({', '.join(sorted(in_b[name]))}): its runs are different scenes and are not compared"
            for name in sorted(set(in_a) & set(in_b)) if in_a[name] != in_b[name]}


def compare_runs(frame_a: pd.DataFrame, frame_b: pd.DataFrame
                 ) -> tuple[pd.DataFrame, pd.DataFrame, list[tuple[str, str]]]:
    """Compare two matrix runs row by row, matched on ``run_identity`` (scene name and physics, integrator,
    exact setting).

    Returns (mismatches, costs, unmatched): one mismatch line per differing deterministic column of a row
    (``DETERMINISTIC_COLUMNS``; must be empty for the same matrix and code on the same machine), the costs of A
    and B and their ratio B/A per row (``<cost>_a``, ``<cost>_b``, ``<cost>_ratio_b_over_a``), and the runs
    present in only one of the two as (side ``"A"`` or ``"B"``, run), sorted. A ratio is given only where both
    costs are finite and positive: a compile time of 0 or below (nothing compiled, or a cached compile: the
    first call was no slower than the others) or a missing cost (a failed run) has no meaningful ratio, and
    gives NaN. Runs of one name and other physics (``scene_differences``) never match.
    """
    import numpy as np
    import pandas as pd

    left = frame_a.assign(run=run_identity(frame_a, frame_b), scene=scene_labels(frame_a, frame_b))
    right = frame_b.assign(run=run_identity(frame_b, frame_a), scene=scene_labels(frame_b, frame_a))
    merged = left.merge(right, on=["run", "scene", "integrator"], suffixes=("_a", "_b"), how="inner")
    unmatched = sorted([("A", run) for run in set(left["run"]) - set(right["run"])]
                       + [("B", run) for run in set(right["run"]) - set(left["run"])])
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
