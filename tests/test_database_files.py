"""Results database files as a careless user hands them over: damaged pages, a newer schema, a read-only folder.

Every command that opens a database (run, results, check, advise, report) answers a database it cannot use with
exit status 2 and one line, never a traceback, and changes nothing in it; a read-only command never changes a
database's journal mode, and reads a write-ahead-log database in a folder it cannot write.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from foucault_bench.bench.cli import main as cli_main

MATRIX_TOML = ('name = "tiny"\nscenes = ["seed_2min"]\nintegrators = ["rk4", "cvode_bdf"]\nkh = [0.2]\ntol = [1e-6]\n'
               "[timing]\nmin_repeats = 1\nmin_total_s = 0.0\nmax_repeats = 1\n")
THRESHOLDS_TOML = ('description = "test gate"\n[[bound]]\nscene = ["seed_2min"]\nintegrator = "rk4"\n'
                   'column = "reference_error"\nmax = 1.0\nbasis = "test: any finite error"\n')


@pytest.fixture(scope="module")
def real_database(tmp_path_factory, fresh_reference_cache) -> tuple[Path, Path, Path]:
    """A database written by `foucault-bench run` of a two-run matrix (WAL mode, closed: no -wal file), the
    matrix file and a thresholds file that its rows pass."""
    folder = tmp_path_factory.mktemp("real")
    matrix, thresholds, database = folder / "tiny.toml", folder / "gate.toml", folder / "runs.sqlite"
    matrix.write_text(MATRIX_TOML, encoding="utf-8")
    thresholds.write_text(THRESHOLDS_TOML, encoding="utf-8")
    assert cli_main(["run", "--matrix", str(matrix), "--db", str(database), "--jobs", "1", "--no-progress"]) == 0
    assert not Path(f"{database}-wal").exists()
    from foucault_bench.bench.problems.scene_key import scene_key
    from foucault_bench.bench.problems.scenes import SCENES

    with sqlite3.connect(f"{database.as_uri()}?mode=ro", uri=True) as connection:  # every row carries its key
        keys = {key for (key,) in connection.execute("SELECT scene_key FROM runs")}
    connection.close()
    assert keys == {scene_key(SCENES["seed_2min"])}
    return database, matrix, thresholds


def _commands(database: Path, matrix: Path, thresholds: Path, out: Path) -> dict[str, list[str]]:
    return {
        "results": ["results", "--db", str(database)],
        "results --compare": ["results", "--db", str(database), "--compare", "latest", "latest"],
        "check --results": ["check", "--thresholds", str(thresholds), "--results", str(database)],
        "advise --no-search": ["advise", "--scene", "seed_2min", "--target", "reference_error=1e-3", "--db",
                               str(database), "--no-search"],
        "report": ["report", "--db", str(database), "--out", str(out), "--studies", "skip"],
        "run": ["run", "--matrix", str(matrix), "--db", str(database), "--jobs", "1", "--no-progress"],
    }


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _damage_data_pages(path: Path) -> int:
    """Flip every bit of the first byte (the b-tree page type) of every page after the first, which holds the
    file header and the schema: the tables are still listed, their pages are garbage. Returns the pages hit."""
    data = bytearray(path.read_bytes())
    page_size = int.from_bytes(data[16:18], "big")
    page_size = 65536 if page_size == 1 else page_size  # the file format's encoding of 64 KiB
    pages = len(data) // page_size
    for page in range(1, pages):
        data[page * page_size] ^= 0xFF
    path.write_bytes(bytes(data))
    return pages - 1


@pytest.mark.parametrize("command", ["results", "results --compare", "check --results", "advise --no-search",
                                     "report", "run"])
def test_a_damaged_database_is_one_line_and_exit_2(real_database, tmp_path, capsys, command) -> None:
    database, matrix, thresholds = real_database
    damaged = tmp_path / "damaged.sqlite"
    shutil.copyfile(database, damaged)
    assert _damage_data_pages(damaged) >= 2
    status = cli_main(_commands(damaged, matrix, thresholds, tmp_path / "report")[command])
    captured = capsys.readouterr()
    lines = [line for line in captured.err.strip().splitlines()
             if not line.startswith("matrix 'tiny'")]  # what `run` says it is about to do
    assert status == 2, captured.err
    assert "Traceback" not in captured.err and len(lines) == 1, captured.err
    assert str(damaged) in lines[0] and "damaged" in lines[0] and "malformed" in lines[0]


def _future_database(path: Path) -> None:
    """A results database of schema version 99, in SQLite's default rollback-journal mode."""
    with sqlite3.connect(path) as connection:
        connection.execute("CREATE TABLE runs (run_key TEXT, matrix_id TEXT, status TEXT)")
        connection.execute("CREATE TABLE matrix_runs (matrix_id TEXT, matrix_hash TEXT, status TEXT)")
        connection.execute("PRAGMA user_version = 99")
    connection.close()


@pytest.mark.parametrize("command", ["run", "advise", "check --db", "results", "report"])
def test_a_newer_schema_is_refused_before_anything_in_it_changes(real_database, tmp_path, capsys, command) -> None:
    """The version is read read-only first: the file keeps its bytes and its journal mode, and SQLite leaves no
    -wal or -shm file (the old code switched it to WAL before refusing it)."""
    _, matrix, thresholds = real_database
    future = tmp_path / "future.sqlite"
    _future_database(future)
    before = _digest(future)
    argv = {
        "run": ["run", "--matrix", str(matrix), "--db", str(future), "--jobs", "1", "--no-progress"],
        "advise": ["advise", "--scene", "seed_2min", "--target", "reference_error=1e-3", "--db", str(future)],
        "check --db": ["check", "--thresholds", str(thresholds), "--matrix", str(matrix), "--db", str(future),
                       "--jobs", "1", "--no-progress"],
        "results": ["results", "--db", str(future)],
        "report": ["report", "--db", str(future), "--out", str(tmp_path / "report"), "--studies", "skip"],
    }[command]
    status = cli_main(argv)
    lines = [line for line in capsys.readouterr().err.strip().splitlines() if not line.startswith("matrix 'tiny'")]
    assert status == 2 and len(lines) == 1 and "newer than this foucault-bench reads" in lines[0], lines
    assert _digest(future) == before
    assert sorted(path.name for path in tmp_path.iterdir()) == ["future.sqlite"]


REPORT_LOADING = """
import sys
from pathlib import Path
from foucault_bench.reports import build

def count(inputs, folder, **options):
    print(len(inputs.runs), "runs")
    return folder / "index.html", folder / "REPORT.md"

build.build_report = count
sys.exit(build.write_report(Path(sys.argv[1]), None, Path(sys.argv[2]), studies="skip"))
"""
"""``foucault-bench report``'s loading of a database (``reports.build.write_report``) with the drawing replaced by
a count of the runs it was handed."""


READ_ONLY_WAYS = ("a read-only mount", "no write permission")
"""The two ways a folder is read-only, which SQLite reports differently: a read-only file system makes the -shm
file impossible to open (SQLITE_CANTOPEN), a folder without write permission one it may not create
(SQLITE_READONLY_DIRECTORY)."""
DROP_FILE_CAPABILITIES = ["setpriv", "--bounding-set=-dac_override,-dac_read_search,-fowner"]
"""A root process ignores permission bits; without these capabilities it obeys them as any user does."""


def _read_only_runner(folder: Path, way: str = READ_ONLY_WAYS[0]):
    """A function running a command line in a subprocess that cannot write ``folder``, made read-only in ``way``
    (``READ_ONLY_WAYS``): a read-only bind mount in a private mount namespace, or the folder's write permission
    removed (for root, with the file capabilities dropped). As a user, both are the permission bits. Skips the
    test where neither is possible."""
    python = [sys.executable]
    if os.geteuid() != 0 or way == "no write permission":
        prefix: list[str] = []
        if os.geteuid() == 0:
            if shutil.which("setpriv") is None or subprocess.run(
                    [*DROP_FILE_CAPABILITIES, "true"], capture_output=True).returncode != 0:
                pytest.skip("cannot drop root's file capabilities here (no setpriv)")
            prefix = DROP_FILE_CAPABILITIES

        def run(argv: list[str]) -> subprocess.CompletedProcess:
            folder.chmod(0o555)
            try:
                return subprocess.run(prefix + python + argv, capture_output=True, text=True, timeout=600)
            finally:
                folder.chmod(0o755)
        return run
    mount = 'mount --bind "$0" "$0" && mount -o remount,ro,bind "$0" && exec "$@"'
    if shutil.which("unshare") is None or subprocess.run(
            ["unshare", "-m", "sh", "-c", mount, str(folder), "true"], capture_output=True).returncode != 0:
        pytest.skip("cannot make a read-only folder here (root without mount namespaces)")

    def run_mounted(argv: list[str]) -> subprocess.CompletedProcess:
        return subprocess.run(["unshare", "-m", "sh", "-c", mount, str(folder), *python, *argv],
                              capture_output=True, text=True, timeout=600)
    return run_mounted


@pytest.mark.parametrize("way", READ_ONLY_WAYS)
def test_a_wal_database_in_a_read_only_folder_is_read_by_results_check_and_report(real_database, tmp_path,
                                                                                   way: str) -> None:
    """SQLite cannot open a WAL database read-only where it cannot create the -shm file (sqlite.org/wal.html):
    the store opens it immutable there. What the commands print is the database's own content."""
    database, _, thresholds = real_database
    folder = tmp_path / "read-only"
    folder.mkdir()
    copy = folder / "runs.sqlite"
    shutil.copyfile(database, copy)
    with sqlite3.connect(f"{copy.as_uri()}?mode=ro", uri=True) as connection:
        assert connection.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        matrix_id, rows = connection.execute(
            "SELECT matrix_id, (SELECT COUNT(*) FROM runs) FROM matrix_runs").fetchone()
    connection.close()
    for leftover in folder.glob("runs.sqlite-*"):  # the reader above leaves SQLite's -wal and -shm
        leftover.unlink()
    before = _digest(copy)
    run = _read_only_runner(folder, way)
    cli = ["-m", "foucault_bench.bench.cli"]
    listed = run([*cli, "results", "--db", str(copy)])
    assert listed.returncode == 0, listed.stderr
    assert matrix_id in listed.stdout and "seed_2min" in listed.stdout
    checked = run([*cli, "check", "--thresholds", str(thresholds), "--results", str(copy)])
    assert checked.returncode == 0 and f"matrix run {matrix_id}" in checked.stderr, checked.stderr
    loaded = run(["-c", REPORT_LOADING, str(copy), str(tmp_path / "report")])  # the report's reading, not drawing
    assert loaded.returncode == 0, loaded.stderr
    assert loaded.stdout.split()[:2] == [str(rows), "runs"]
    assert _digest(copy) == before and sorted(path.name for path in folder.iterdir()) == ["runs.sqlite"]


def test_an_older_database_in_a_read_only_folder_is_read_as_it_is(real_database, tmp_path) -> None:
    """A version-2 database (no scene_key column) that cannot be migrated is read with the missing column
    unknown: results lists its rows, advise --no-search says they are of unknown physics and uses none."""
    database, _, _ = real_database
    folder = tmp_path / "read-only"
    folder.mkdir()
    old = folder / "old.sqlite"
    shutil.copyfile(database, old)
    with sqlite3.connect(old) as connection:
        connection.execute("PRAGMA journal_mode=DELETE")
        connection.execute("ALTER TABLE runs DROP COLUMN scene_key")
        connection.execute("ALTER TABLE adequacy DROP COLUMN scene_key")
        connection.execute("PRAGMA user_version = 2")
        rows = connection.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    connection.close()
    before = _digest(old)
    run = _read_only_runner(folder)
    cli = ["-m", "foucault_bench.bench.cli"]
    listed = run([*cli, "results", "--db", str(old)])
    assert listed.returncode == 0, listed.stderr
    summary = [line for line in listed.stdout.splitlines() if line.startswith("seed_2min ")]
    assert len(summary) == 2  # rk4 and cvode_bdf
    advised = run([*cli, "advise", "--scene", "seed_2min", "--target", "reference_error=1", "--db", str(old),
                   "--no-search"])
    assert advised.returncode == 1, advised.stderr  # nothing of a known physics to recommend
    assert f"note: {rows} stored runs named seed_2min come from an older database" in advised.stdout
    assert _digest(old) == before and sorted(path.name for path in folder.iterdir()) == ["old.sqlite"]
