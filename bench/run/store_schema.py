"""The results database's tables: their columns, the schema version, and how a file is opened and migrated.

What ``bench.run.store.ResultsStore`` relies on before it reads or writes a row: the ``runs`` table has the
columns of ``bench.schema.COLUMNS`` and ``matrix_runs`` those of ``MATRIX_RUN_COLUMNS``; SQLite's
``PRAGMA user_version`` records ``bench.schema.SCHEMA_VERSION``; an existing file is first read read-only
(``read_only_connection``, ``check_readable``), so that a database this code cannot read is refused before
anything in it changes; a database of an older version gets the columns it lacks (``migrate``, NULL in its old
rows; ``bench.schema.MIGRATIONS``) and the scene keys that can be proved (``recover_scene_keys``).
"""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path
from typing import Any

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.schema import COLUMN_NAMES, COLUMNS, MIGRATIONS, SCHEMA_VERSION

RUNS_TABLE = "runs"
MATRIX_RUNS_TABLE = "matrix_runs"
ADEQUACY_TABLE = "adequacy"
RESERVED_TABLES = (RUNS_TABLE, MATRIX_RUNS_TABLE, ADEQUACY_TABLE)

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


DAMAGED_CODES = (sqlite3.SQLITE_CORRUPT, sqlite3.SQLITE_NOTADB)
"""SQLite result codes of a damaged file (sqlite.org/rescode.html: SQLITE_CORRUPT "database disk image is
malformed", SQLITE_NOTADB "file is not a database")."""


CANNOT_MAKE_WAL_FILES = (sqlite3.SQLITE_CANTOPEN, sqlite3.SQLITE_READONLY)
"""SQLite's primary result codes when it cannot open or create a WAL database's ``-shm`` file: CANTOPEN on a
read-only file system, READONLY (extended code SQLITE_READONLY_DIRECTORY) in a folder without write permission
(sqlite.org/rescode.html)."""


def read_only_connection(path: Path) -> sqlite3.Connection:
    """A read-only connection (SQLite URI ``mode=ro``) to the database ``path``, its schema version read.

    Never changes the file or its journal mode. SQLite opens a write-ahead-log (WAL) database read-only only if
    its ``-shm`` and ``-wal`` files exist or can be created, or if the database is opened as immutable
    (sqlite.org/wal.html, "Read-Only Databases", SQLite ≥ 3.22). So when SQLite cannot open the file
    (``CANNOT_MAKE_WAL_FILES``) in a folder this process cannot write, and no ``-wal`` file holds changes
    (everything is in the main file), it is opened with ``immutable=1`` (sqlite.org/uri.html): safe there, since
    no writer can change it either (a writer needs its ``-wal`` or journal file in that folder). A ``-wal`` file
    holding changes in such a folder cannot be read without its ``-shm``: ``InputError``, with what to do. A
    reader of a WAL database in a writable folder leaves the ``-wal`` and ``-shm`` files, as every SQLite reader
    does; they are SQLite's, not a change of mode.
    """
    uri = path.resolve().as_uri()
    connection = sqlite3.connect(f"{uri}?mode=ro", uri=True, timeout=30.0)
    try:
        connection.execute("PRAGMA user_version").fetchone()
        return connection
    except sqlite3.OperationalError as error:
        connection.close()
        primary_code = getattr(error, "sqlite_errorcode", 0) & 0xFF
        if primary_code not in CANNOT_MAKE_WAL_FILES or os.access(path.parent, os.W_OK):
            raise
    log = Path(f"{path}-wal")
    if log.exists() and log.stat().st_size > 0:
        raise InputError(f"{path}: a write-ahead-log database whose {log.name} holds changes SQLite cannot read in "
                         "a folder it cannot write; copy the database and its -wal file to a writable folder")
    connection = sqlite3.connect(f"{uri}?mode=ro&immutable=1", uri=True, timeout=30.0)
    connection.execute("PRAGMA user_version").fetchone()
    return connection


def schema_version(connection: sqlite3.Connection) -> int:
    """The results schema version recorded in the database (``bench.schema.SCHEMA_VERSION``)."""
    return connection.execute("PRAGMA user_version").fetchone()[0]


def table_exists(connection: sqlite3.Connection, name: str) -> bool:
    return connection.execute(
        "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?", (name,)).fetchone() is not None


def table_names(connection: sqlite3.Connection) -> set[str]:
    return {row[0] for row in connection.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}


def is_results_database(connection: sqlite3.Connection) -> bool:
    """Both tables of the suite are there with their key columns."""
    tables = table_names(connection)
    if not {RUNS_TABLE, MATRIX_RUNS_TABLE} <= tables:
        return False
    runs = {row[1] for row in connection.execute(f"PRAGMA table_info({RUNS_TABLE})")}
    matrix_runs = {row[1] for row in connection.execute(f"PRAGMA table_info({MATRIX_RUNS_TABLE})")}
    return {"run_key", "matrix_id", "status"} <= runs and {"matrix_id", "matrix_hash", "status"} <= matrix_runs


def select_list(connection: sqlite3.Connection) -> str:
    """The run columns in ``COLUMNS`` order, those the table lacks as NULL: a database of an older schema
    version that could not be migrated (its file or folder is read-only) is read as it is, its missing
    columns unknown; a migrated one holds its added columns last."""
    stored = {row[1] for row in connection.execute(f"PRAGMA table_info({RUNS_TABLE})")}
    return ", ".join(name if name in stored else f"NULL AS {name}" for name in COLUMN_NAMES)


def check_readable(path: Path, *, create: bool) -> int:
    """Read the existing file's schema version and tables read-only and refuse (``InputError``, nothing
    changed) a database this code cannot use; return the version."""
    connection = read_only_connection(path)
    try:
        version = schema_version(connection)
        tables = table_names(connection)
        if version > SCHEMA_VERSION:
            raise InputError(f"{path}: written with results schema version {version}, newer than "
                             f"this foucault-bench reads ({SCHEMA_VERSION}): upgrade foucault-bench"
                             + (" or use another --db" if create else "") + "; nothing was changed")
        if not is_results_database(connection) and (tables or not create):
            raise InputError(
                f"{path}: an SQLite database of something else (tables "
                f"{', '.join(sorted(tables)[:5])}); give another --db" if create and tables else
                f"{path}: not a foucault-bench results database (no {RUNS_TABLE} and "
                f"{MATRIX_RUNS_TABLE} tables); nothing was changed")
        if version < SCHEMA_VERSION and table_exists(connection, RUNS_TABLE) and max(version, 1) not in MIGRATIONS:
            raise InputError(f"{path}: results schema version {version} cannot be migrated to "
                             f"{SCHEMA_VERSION}; use another --db")
        return version
    finally:
        connection.close()


def create_tables(connection: sqlite3.Connection, path: Path) -> None:
    """Create the tables of a new database, or check (and migrate) the schema version of an existing one."""
    version = connection.execute("PRAGMA user_version").fetchone()[0]
    if version > SCHEMA_VERSION:
        raise InputError(f"{path}: written with results schema version {version}, newer than this "
                         f"foucault-bench reads ({SCHEMA_VERSION}): upgrade foucault-bench or use another --db")
    if version < SCHEMA_VERSION and table_exists(connection, RUNS_TABLE):
        migrate(connection, path, max(version, 1))  # a database from before versioning (user_version 0) is version 1
    runs = ", ".join(f"{column.name} {column.sql_type}" for column in COLUMNS)
    matrix_runs = ", ".join(f"{name} {sql_type}" for name, sql_type in MATRIX_RUN_COLUMNS)
    with connection:
        connection.execute(
            f"CREATE TABLE IF NOT EXISTS {RUNS_TABLE} ({runs}, PRIMARY KEY (matrix_id, run_key))"
        )
        connection.execute(f"CREATE TABLE IF NOT EXISTS {MATRIX_RUNS_TABLE} ({matrix_runs})")
        connection.execute(f"PRAGMA user_version = {SCHEMA_VERSION:d}")


def migrate(connection: sqlite3.Connection, path: Path, version: int) -> None:
    """Bring a database of an older schema version up to ``SCHEMA_VERSION`` by adding the columns it lacks
    (``bench.schema.MIGRATIONS`` says which; their values are NULL, i.e. unknown, in the old rows). A
    database whose tables hold columns the schema does not know is refused, never misread."""
    if version not in MIGRATIONS:
        raise InputError(f"{path}: results schema version {version} cannot be migrated to "
                         f"{SCHEMA_VERSION}; use another --db")
    for table, wanted in ((RUNS_TABLE, [(column.name, column.sql_type) for column in COLUMNS]),
                          (MATRIX_RUNS_TABLE, [(name, sql_type.split()[0]) for name, sql_type in MATRIX_RUN_COLUMNS])):
        if not table_exists(connection, table):
            continue
        stored = [row[1] for row in connection.execute(f"PRAGMA table_info({table})")]
        unknown = sorted(set(stored) - {name for name, _ in wanted})
        if unknown:
            raise InputError(f"{path}: table {table} has columns results schema version {SCHEMA_VERSION} "
                             f"does not define ({', '.join(unknown)}): not a foucault-bench results database "
                             "this version can read; use another --db")
        with connection:
            for name, sql_type in wanted:
                if name not in stored:
                    connection.execute(f"ALTER TABLE {table} ADD COLUMN {name} {sql_type}")
    recover_scene_keys(connection)


def recover_scene_keys(connection: sqlite3.Connection) -> None:
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

    rows = connection.execute(
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
    with connection:
        connection.executemany(f"UPDATE {RUNS_TABLE} SET scene_key = ? WHERE rowid = ?", updates)
        if table_exists(connection, ADEQUACY_TABLE):
            stored = {row[1] for row in connection.execute(f"PRAGMA table_info({ADEQUACY_TABLE})")}
            if "scene_key" not in stored:
                connection.execute(f"ALTER TABLE {ADEQUACY_TABLE} ADD COLUMN scene_key TEXT")
            connection.execute(  # the key of the runs of that matrix run and name, where they have one
                f"UPDATE {ADEQUACY_TABLE} SET scene_key = (SELECT MIN(r.scene_key) FROM {RUNS_TABLE} r "
                f"WHERE r.matrix_id = {ADEQUACY_TABLE}.matrix_id AND r.scene = {ADEQUACY_TABLE}.scene "
                f"HAVING COUNT(DISTINCT r.scene_key) = 1 AND COUNT(r.scene_key) = COUNT(*)) "
                "WHERE scene_key IS NULL")
