"""Outputs never destroy inputs or the user's files, and a failed write leaves the old output whole.

* an output path that is an input (same file by any name: ``./X``, a symlink, a hard link, the database's
  ``-wal``/``-shm``) or another output is refused with exit status 2 and one line, before anything is written;
* files are written through a temporary file and a rename (``bench.atomic.replacing_file``): a full disk
  (ENOSPC or EDQUOT, simulated here and, as root, real on a small tmpfs) is one line, exit status 2, the old file
  unchanged and no temporary file left;
* ``report --out`` and ``seed --out`` replace only an empty folder or one they wrote (its marker), else need
  ``--force``; never the root, the home folder, the current folder or its ancestors, or a folder holding the
  database; an existing file, a path under a file, a read-only folder are refused before any work;
* leftovers of a killed build are repaired by the next run (the kill tests themselves: test_report_kill.py);
* ``report --studies stored`` on a read-only database computes the missing studies without storing them.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from xml.etree import ElementTree

import pandas as pd
import pytest

from foucault_bench.bench.atomic import MARKER, read_marker, recover, replacing_file, write_text_file
from foucault_bench.bench.cli import main as cli_main
from output_fixtures import (
    CAN_MOUNT,
    QUICK_ENVIRONMENT,
    folder_digest,
    full_disk,
    in_mount_namespace,
    leftovers,
    processes_running,
    quick_report_command,
    read_only_setup,
    tiny_database,
)

THRESHOLDS = """
[[bound]]
scene = "lab"
integrator = "rk4"
column = "reference_error"
max = 1.0
basis = "any finite error passes: these tests are about the files written, not the bound"
"""


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def error_lines(capsys) -> list[str]:
    """The non-blank lines of stderr as a terminal shows them: a progress bar erased by carriage returns
    (``leave=False``) leaves nothing, so each line is its text after its last carriage return."""
    err = capsys.readouterr().err
    assert "Traceback" not in err
    shown = [line.rsplit("\r", 1)[-1] for line in err.split("\n")]
    return [line for line in shown if line.strip()]


@pytest.fixture
def database(tmp_path) -> Path:
    path = tmp_path / "results.sqlite"
    tiny_database(path)
    return path


def spelled(path: Path, spelling: str, tmp_path: Path, monkeypatch) -> str:
    """Another name of ``path``: itself, ``./name`` from its folder, a symlink, a hard link, its -wal file."""
    if spelling == "dot":
        monkeypatch.chdir(path.parent)
        return f"./{path.name}"
    if spelling == "symlink":
        (tmp_path / "link").symlink_to(path)
        return str(tmp_path / "link")
    if spelling == "hard link":
        os.link(path, tmp_path / "hard")
        return str(tmp_path / "hard")
    if spelling == "wal":
        return f"{path}-wal"
    return str(path)


# --- 1. an output is never an input --------------------------------------------------------------------------
@pytest.mark.parametrize("spelling", ["same", "dot", "symlink", "hard link", "wal"])
@pytest.mark.parametrize("option", ["--csv", "--parquet"])
def test_an_export_onto_its_database_is_refused(database, tmp_path, monkeypatch, capsys, option, spelling):
    before = sha256(database)
    output = spelled(database, spelling, tmp_path, monkeypatch)
    assert cli_main(["results", "--db", str(database), option, output]) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and "same file as --db" in lines[0], lines
    assert sha256(database) == before


def test_csv_and_parquet_onto_one_file_are_refused(database, tmp_path, capsys):
    output = tmp_path / "rows.out"
    assert cli_main(["results", "--db", str(database), "--csv", str(output), "--parquet", str(output)]) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and "same file as --csv" in lines[0]
    assert not output.exists()


@pytest.fixture
def thresholds(tmp_path) -> Path:
    path = tmp_path / "gate.toml"
    path.write_text(THRESHOLDS, encoding="utf-8")
    return path


@pytest.mark.parametrize("victim", ["--results", "--thresholds"])
def test_junit_onto_an_input_of_the_check_is_refused(database, thresholds, tmp_path, monkeypatch, capsys, victim):
    target = database if victim == "--results" else thresholds
    before = sha256(target)
    junit = spelled(target, "symlink", tmp_path, monkeypatch)
    assert cli_main(["check", "--thresholds", str(thresholds), "--results", str(database), "--junit", junit]) == 2
    lines = error_lines(capsys)
    expected = "is a SQLite database" if victim == "--results" else f"same file as {victim}"
    assert len(lines) == 1 and expected in lines[0], lines
    assert sha256(target) == before


@pytest.mark.parametrize("command", [
    ["results", "--db", "{database}", "--csv", "{victim}"],
    ["results", "--db", "{database}", "--parquet", "{victim}"],
    ["check", "--thresholds", "{thresholds}", "--results", "{database}", "--junit", "{victim}"],
    ["perf", "--quick", "--only", "startup", "--markdown", "{victim}"],
], ids=["csv", "parquet", "junit", "perf markdown"])
@pytest.mark.parametrize("victim_kind", ["another database", "its -wal file", "its -journal file"])
def test_no_file_output_is_written_over_a_database(database, thresholds, tmp_path, capsys, command, victim_kind):
    """An output file that is a SQLite database (any database, not only the command's own input), or a file SQLite
    keeps beside one, is refused before any work: writing it would destroy the runs it holds."""
    other = tmp_path / "other.sqlite"
    tiny_database(other)
    victim = {"another database": other, "its -wal file": Path(f"{other}-wal"),
              "its -journal file": Path(f"{other}-journal")}[victim_kind]
    if not victim.exists():
        victim.write_bytes(b"SQLite's own bytes")
    before = {path: sha256(path) for path in (other, victim)}
    argv = [part.format(database=database, thresholds=thresholds, victim=victim) for part in command]
    assert cli_main(argv) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and str(victim) in lines[0] and "SQLite" in lines[0], lines
    assert {path: sha256(path) for path in (other, victim)} == before


def test_a_fresh_check_run_refuses_outputs_onto_its_matrix_or_each_other(thresholds, tmp_path, capsys):
    matrix = tmp_path / "m.toml"
    matrix.write_text("# any matrix: the check refuses before reading it\n", encoding="utf-8")
    run_db = tmp_path / "fresh.sqlite"
    assert cli_main(["check", "--thresholds", str(thresholds), "--matrix", str(matrix), "--junit", str(matrix)]) == 2
    assert "same file as --matrix" in error_lines(capsys)[0]
    assert cli_main(["check", "--thresholds", str(thresholds), "--matrix", str(matrix), "--db", str(run_db),
                     "--junit", str(run_db)]) == 2
    assert "same file as --db" in error_lines(capsys)[0]
    assert matrix.read_text(encoding="utf-8").startswith("# any matrix") and not run_db.exists()


def test_the_check_still_writes_its_junit_file(database, thresholds, tmp_path, capsys):
    junit = tmp_path / "junit.xml"
    junit.write_text("old", encoding="utf-8")
    assert cli_main(["check", "--thresholds", str(thresholds), "--results", str(database), "--junit", str(junit)]) == 0
    cases = ElementTree.parse(junit).getroot().iter("testcase")
    assert len(list(cases)) == 3  # the bound selects the three rk4 rows of the tiny database
    assert leftovers(tmp_path) == []


# --- atomic files: a full disk loses nothing -----------------------------------------------------------------
def _fill_then_fail(code: int):
    def write(self, path, *args, **kwargs):
        Path(path).write_text("half a fi", encoding="utf-8")
        raise OSError(code, os.strerror(code))
    return write


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EDQUOT])
def test_a_full_disk_during_a_csv_export_keeps_the_old_file(database, tmp_path, monkeypatch, capsys, code):
    output = tmp_path / "rows.csv"
    output.write_text("the old export\n", encoding="utf-8")
    monkeypatch.setattr(pd.DataFrame, "to_csv", _fill_then_fail(code))
    assert cli_main(["results", "--db", str(database), "--csv", str(output)]) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and os.strerror(code) in lines[0] and "unchanged" in lines[0]
    assert output.read_text(encoding="utf-8") == "the old export\n"
    assert leftovers(tmp_path) == []


def test_a_full_disk_during_junit_keeps_the_old_file(database, thresholds, tmp_path, monkeypatch, capsys):
    junit = tmp_path / "junit.xml"
    junit.write_text("<old/>", encoding="utf-8")
    monkeypatch.setattr(ElementTree.ElementTree, "write", _fill_then_fail(errno.ENOSPC))
    assert cli_main(["check", "--thresholds", str(thresholds), "--results", str(database), "--junit", str(junit)]) == 2
    lines = [line for line in error_lines(capsys) if "error:" in line]
    assert len(lines) == 1 and "No space left on device" in lines[0]
    assert junit.read_text(encoding="utf-8") == "<old/>"
    assert leftovers(tmp_path) == []


def test_a_replaced_file_keeps_its_mode_and_its_symlink(tmp_path):
    real = tmp_path / "real.md"
    real.write_text("old", encoding="utf-8")
    real.chmod(0o640)
    (tmp_path / "link.md").symlink_to(real)
    write_text_file(tmp_path / "link.md", "new", "--markdown")
    assert (tmp_path / "link.md").is_symlink() and real.read_text(encoding="utf-8") == "new"
    assert real.stat().st_mode & 0o777 == 0o640
    with pytest.raises(RuntimeError), replacing_file(real, "--markdown") as temporary:  # not an OSError: raised
        temporary.write_text("never", encoding="utf-8")
        raise RuntimeError("a bug in the writer")
    assert real.read_text(encoding="utf-8") == "new" and leftovers(tmp_path) == []


def cli_command(*arguments: str | Path) -> list[str]:
    return [sys.executable, "-m", "foucault_bench.bench.cli", *map(str, arguments)]


@pytest.mark.skipif(not CAN_MOUNT, reason="needs root and unshare for a private mount namespace")
def test_a_command_past_its_time_limit_in_a_mount_namespace_leaves_no_process() -> None:
    """The tests' helper that runs a command on a full or read-only mount kills the command's own children too when
    it times out (a hung report's pool workers), not only the shell it started."""
    child = f"sleep {os.getpid()}.25"  # unique to this test
    with pytest.raises(subprocess.TimeoutExpired):
        in_mount_namespace("true", ["sh", "-c", f"{child} & {child}"], timeout=1)
    deadline = time.monotonic() + 10.0  # SIGKILL is at once; a reparented child may take a moment to be reaped
    while processes_running(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert processes_running(child) == []


@pytest.mark.skipif(not CAN_MOUNT, reason="needs root and unshare for a private tmpfs")
def test_a_real_full_disk_loses_no_export_and_prints_no_traceback(database, thresholds, tmp_path):
    disk = tmp_path / "disk"
    disk.mkdir()
    (disk / "rows.csv").write_text("the old export\n", encoding="utf-8")
    (disk / "junit.xml").write_text("<old/>", encoding="utf-8")
    setup, teardown, after = full_disk(disk, 256)
    commands = (cli_command("results", "--db", database, "--csv", disk / "rows.csv"),
                cli_command("check", "--thresholds", thresholds, "--results", database, "--junit", disk / "junit.xml"))
    script = " ; ".join(f"{' '.join(command)} ; echo status=$?" for command in commands)
    done = in_mount_namespace(setup, ["sh", "-c", script], teardown, timeout=300)
    assert done.stdout.count("status=2") == 2, (done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    assert done.stderr.count("No space left on device") == 2, done.stderr
    assert (after / "rows.csv").read_text(encoding="utf-8") == "the old export\n"
    assert (after / "junit.xml").read_text(encoding="utf-8") == "<old/>"
    assert leftovers(after) == []


# --- 2. report and seed folders ------------------------------------------------------------------------------
@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if the report or seed starts working (the checks must come first)."""
    import foucault_bench.reports.build as build
    import foucault_bench.reports.seed as seed

    def started(*args, **kwargs):
        raise AssertionError("the command started working before refusing its --out")

    monkeypatch.setattr(build, "write_report", started)
    monkeypatch.setattr(seed, "write_seed", started)


@pytest.mark.parametrize("command", ["report", "seed"])
def test_a_folder_of_the_user_s_is_refused_without_force(database, tmp_path, capsys, no_work, command):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "index.html").write_text("my own page", encoding="utf-8")
    (folder / "figures").mkdir()
    (folder / "figures" / "photo.png").write_bytes(b"\x89PNG mine")
    before = folder_digest(folder)
    arguments = [command, "--out", str(folder)] + (["--db", str(database)] if command == "report" else [])
    assert cli_main(arguments) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and "--force" in lines[0] and MARKER in lines[0]
    assert folder_digest(folder) == before and leftovers(tmp_path) == []


FORBIDDEN = ("root", "home", "current folder", "parent of the current folder", "folder of the database")


@pytest.mark.parametrize(("command", "which"), [("report", which) for which in FORBIDDEN]
                         + [("seed", which) for which in FORBIDDEN if "database" not in which])
def test_some_folders_are_never_replaced_even_with_force(database, tmp_path, monkeypatch, capsys, no_work,
                                                         command, which):
    work = tmp_path / "work"
    (work / "deeper").mkdir(parents=True)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home").mkdir()
    monkeypatch.chdir(work / "deeper" if "current" in which else "/")
    out = {"root": "/", "home": str(tmp_path / "home"), "current folder": ".", "parent of the current folder": "..",
           "folder of the database": str(tmp_path)}[which]
    arguments = [command, "--out", out, "--force"] + (["--db", str(database)] if command == "report" else [])
    assert cli_main(arguments) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1, lines
    assert {"root": "root of the file system", "home": "home folder", "current folder": "current folder",
            "parent of the current folder": "current folder", "folder of the database": "holds --db"}[which] in lines[0]


@pytest.mark.parametrize("command", ["report", "seed"])
def test_an_out_that_is_a_file_or_under_one_is_refused_before_any_work(database, tmp_path, capsys, no_work, command):
    a_file = tmp_path / "notes.txt"
    a_file.write_text("mine", encoding="utf-8")
    for out, words in ((a_file, "not a folder"), (a_file / "report", "is a file")):
        arguments = [command, "--out", str(out)] + (["--db", str(database)] if command == "report" else [])
        assert cli_main(arguments) == 2
        lines = error_lines(capsys)
        assert len(lines) == 1 and words in lines[0], lines
    assert a_file.read_text(encoding="utf-8") == "mine"


def _quick_sections(monkeypatch) -> None:
    """A report without figures and without the seed section: only its tables and documents are written."""
    import foucault_bench.reports.build as build

    from foucault_bench.reports import result_sections, study_sections

    monkeypatch.setattr(build, "SECTIONS", [section for section in build.SECTIONS
                                            if section not in (study_sections.seed_section,
                                                               result_sections.recommendations)])
    monkeypatch.setattr(result_sections, "_scene_work_precision", lambda *arguments: None)
    monkeypatch.setattr(result_sections, "_scene_convergence", lambda *arguments: None)


def test_an_earlier_report_is_replaced_whole_and_a_user_folder_only_with_force(database, tmp_path, monkeypatch,
                                                                                capsys):
    _quick_sections(monkeypatch)
    out = tmp_path / "report"
    assert cli_main(["report", "--db", str(database), "--out", str(out), "--studies", "skip"]) == 0
    marker = read_marker(out)
    assert marker is not None and marker["command"] == "report"
    first = folder_digest(out)
    (out / "tables" / "stale.csv").write_text("from an older version", encoding="utf-8")
    assert cli_main(["report", "--db", str(database), "--out", str(out), "--studies", "skip",
                     "--targets", "1e-4"]) == 0
    second = folder_digest(out)
    assert "tables/stale.csv" not in second and set(second) == set(first)  # replaced whole, not merged
    assert second["tables/matched_accuracy.csv"] != first["tables/matched_accuracy.csv"]
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "index.html").write_text("my own page", encoding="utf-8")
    assert cli_main(["report", "--db", str(database), "--out", str(mine), "--studies", "skip"]) == 2
    assert (mine / "index.html").read_text(encoding="utf-8") == "my own page"
    assert cli_main(["report", "--db", str(database), "--out", str(mine), "--studies", "skip", "--force"]) == 0
    assert set(folder_digest(mine)) == set(first) and read_marker(mine) is not None
    assert leftovers(tmp_path) == []
    capsys.readouterr()


def test_the_report_and_seed_help_name_force(capsys):
    for command in ("report", "seed"):
        with pytest.raises(SystemExit):
            cli_main([command, "--help"])
        assert "--force" in capsys.readouterr().out


def _dead_pid() -> int:
    process = subprocess.Popen(["true"])
    process.wait()
    return process.pid


def test_leftovers_of_a_killed_build_are_repaired_and_live_ones_left_alone(tmp_path):
    target = tmp_path / "report"
    dead, alive = _dead_pid(), 1  # pid 1 (init) runs as long as the machine
    backup = tmp_path / f".report.previous-{dead}-0000"
    backup.mkdir()
    (backup / "index.html").write_text("the previous report", encoding="utf-8")
    (backup / MARKER).write_text(json.dumps({"written_by": "foucault-bench", "command": "report"}), encoding="utf-8")
    unfinished = tmp_path / f".report.building-{dead}-0000"
    unfinished.mkdir()
    (unfinished / "index.html").write_text("half", encoding="utf-8")
    live = tmp_path / f".report.building-{alive}-0000"
    live.mkdir()
    recover(target)
    assert (target / "index.html").read_text(encoding="utf-8") == "the previous report"
    assert not backup.exists() and not unfinished.exists() and live.is_dir()


# --- 14. read-only places, read-only databases ---------------------------------------------------------------
@pytest.mark.skipif(not CAN_MOUNT, reason="needs root and unshare for a read-only mount (root ignores modes)")
@pytest.mark.parametrize("command", ["report", "seed"])
def test_an_out_in_a_read_only_folder_is_one_line_before_any_work(database, tmp_path, command):
    locked = tmp_path / "locked"
    locked.mkdir()
    arguments = [command, "--out", locked / "report"] + (["--db", database] if command == "report" else [])
    done = in_mount_namespace(read_only_setup(locked), cli_command(*arguments), timeout=120)
    assert done.returncode == 2, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "cannot create folders in" in lines[0], lines


TINY_STUDY = """
import pandas as pd
from foucault_bench.bench.studies import STUDIES, Study
STUDIES.clear()  # one tiny study instead of the real ones (minutes): what is tested is where it goes
STUDIES["study_tiny"] = Study("study_tiny", lambda config, progress: pd.DataFrame({"x": [1.0, 2.0]}), None)
"""


@pytest.mark.skipif(not CAN_MOUNT and os.geteuid() == 0, reason="root needs unshare to make a database read-only")
def test_report_on_a_read_only_database_computes_missing_studies_without_storing(tmp_path):
    shelf = tmp_path / "shelf"
    shelf.mkdir()
    database = shelf / "results.sqlite"
    tiny_database(database)
    with sqlite3.connect(database) as connection:  # a WAL database in a read-only folder is the store's matter
        connection.execute("PRAGMA journal_mode=DELETE")
    before = sha256(database)
    command = quick_report_command("--db", database, "--out", tmp_path / "report", "--studies", "stored",
                                   extra=TINY_STUDY)
    if CAN_MOUNT:
        done = in_mount_namespace(read_only_setup(shelf), command, env=QUICK_ENVIRONMENT, timeout=300)
    else:
        database.chmod(0o444)
        shelf.chmod(0o555)
        try:
            done = subprocess.run(command, capture_output=True, text=True, env=QUICK_ENVIRONMENT, timeout=300)
        finally:
            shelf.chmod(0o755)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    assert "read-only: the study tables study_tiny are computed for this report and not stored" in done.stderr
    assert sha256(database) == before and (tmp_path / "report" / "index.html").is_file()


# --- 14. a full disk while a report is built -----------------------------------------------------------------
def test_a_full_disk_while_building_a_report_keeps_the_old_one(database, tmp_path, monkeypatch, capsys):
    _quick_sections(monkeypatch)
    out = tmp_path / "report"
    assert cli_main(["report", "--db", str(database), "--out", str(out), "--studies", "skip"]) == 0
    old = folder_digest(out)
    real_write_text = Path.write_text

    def write_text(self, *args, **kwargs):
        if any(".building-" in part for part in self.parts):  # the disk fills up while the new report is built
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write_text(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", write_text)
    capsys.readouterr()
    assert cli_main(["report", "--db", str(database), "--out", str(out), "--studies", "skip", "--targets", "1e-4"]) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and "No space left on device" in lines[-1] and "unchanged" in lines[-1], lines
    assert folder_digest(out) == old and leftovers(tmp_path) == []


@pytest.mark.skipif(not CAN_MOUNT, reason="needs root and unshare for a private tmpfs")
def test_a_real_full_disk_while_building_a_report_keeps_the_old_one(database, tmp_path, monkeypatch, capsys):
    _quick_sections(monkeypatch)
    disk = tmp_path / "disk"
    assert cli_main(["report", "--db", str(database), "--out", str(disk / "report"), "--studies", "skip"]) == 0
    old = folder_digest(disk / "report")
    setup, teardown, after = full_disk(disk, 4096)
    command = quick_report_command("--db", database, "--out", disk / "report", "--studies", "skip")
    done = in_mount_namespace(setup, command, teardown, env=QUICK_ENVIRONMENT, timeout=300)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if "error:" in line]
    assert len(lines) == 1 and "No space left on device" in lines[0], done.stderr
    assert folder_digest(after / "report") == old and leftovers(after) == []


def test_a_temporary_file_of_a_killed_export_goes_with_the_next_write(tmp_path):
    target = tmp_path / "rows.csv"
    dead = tmp_path / f".rows.csv.partial-{_dead_pid()}-0000"
    dead.write_text("half an export", encoding="utf-8")
    live = tmp_path / ".rows.csv.partial-1-0000"  # pid 1 runs: a write going on
    live.write_text("being written", encoding="utf-8")
    write_text_file(target, "whole", "--csv")
    assert target.read_text(encoding="utf-8") == "whole"
    assert not dead.exists() and live.exists()


def _sqlite_full_error() -> sqlite3.Error:
    """A real SQLITE_FULL ("database or disk is full"): a database limited to its present size, made to grow."""
    connection = sqlite3.connect(":memory:")
    connection.execute("CREATE TABLE filler (blob BLOB)")
    connection.execute("PRAGMA max_page_count = 2")
    try:
        for _ in range(10):
            connection.execute("INSERT INTO filler VALUES (zeroblob(4096))")
    except sqlite3.Error as error:
        return error
    finally:
        connection.close()
    raise AssertionError("the database did not fill up")


def test_a_database_that_fills_up_is_one_line_not_a_traceback(database, tmp_path, monkeypatch, capsys):
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.studies import Study

    _quick_sections(monkeypatch)
    full = _sqlite_full_error()

    def write_table(self, name, frame, **kwargs):
        raise full

    monkeypatch.setattr(ResultsStore, "write_table", write_table)
    tiny = {"study_tiny": Study("study_tiny", lambda config, progress: pd.DataFrame({"x": [1.0]}), None)}
    monkeypatch.setattr("foucault_bench.bench.studies.stored.STUDIES", tiny)  # instead of minutes of real studies
    monkeypatch.setattr("foucault_bench.reports.build.STUDIES", tiny)
    before = sha256(database)
    assert cli_main(["report", "--db", str(database), "--out", str(tmp_path / "report"), "--studies", "stored"]) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and "the disk is full (database or disk is full)" in lines[0], lines
    assert sha256(database) == before and not (tmp_path / "report").exists() and leftovers(tmp_path) == []


TINY_MATRIX = """
name = "tiny_run"
description = "two short runs: enough to write rows"
scenes = ["seed_2min"]
integrators = ["rk4"]
kh = [0.2, 0.1]
[timing]
min_repeats = 1
min_total_s = 0.01
max_repeats = 1
"""


@pytest.mark.skipif(not CAN_MOUNT, reason="needs root and unshare for a private tmpfs")
@pytest.mark.parametrize("free_kb", [0, 40])
def test_a_run_onto_a_real_full_disk_keeps_the_stored_rows(tmp_path, free_kb):
    """With nothing left (the database cannot even open its log) and with a little left (SQLite's own
    SQLITE_FULL on the first insert, measured): one line, exit status 2, the stored matrix run still readable."""
    disk = tmp_path / "disk"
    disk.mkdir()
    stored = tiny_database(disk / "results.sqlite")
    matrix = tmp_path / "tiny_run.toml"
    matrix.write_text(TINY_MATRIX, encoding="utf-8")
    setup, teardown, after = full_disk(disk, 2048)
    if free_kb:
        setup += f"\nrm -f {disk}/filler {disk}/filler2\n" \
                 f"avail=$(df -k {disk} | tail -1 | awk '{{print $4}}')\n" \
                 f"dd if=/dev/zero of={disk}/filler bs=1k count=$((avail - {free_kb})) 2>/dev/null"
    done = in_mount_namespace(setup, cli_command("run", "--matrix", matrix, "--db", disk / "results.sqlite",
                                                 "--jobs", "1", "--no-progress"), teardown, timeout=300)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if "error:" in line]
    assert len(lines) == 1 and ("disk is full" if free_kb else "disk I/O error") in lines[0], done.stderr
    from foucault_bench.bench.run.store import ResultsStore

    with ResultsStore(after / "results.sqlite", create=False) as store:
        assert len(store.frame(stored)) == 3


def test_a_full_disk_while_writing_seed_figures_keeps_the_old_folder(tmp_path, monkeypatch, capsys):
    import foucault_bench.reports.seed as seed

    monkeypatch.setattr(seed, "seed_revisited", lambda: None)  # the study itself: test_seed.py
    monkeypatch.setattr(seed, "seed_blocks", lambda folder, prefix, study: [None])
    out = tmp_path / "seed"
    assert cli_main(["seed", "--out", str(out)]) == 0
    old = folder_digest(out)
    assert {MARKER, "index.html", "SEED.md"} <= set(old)
    real_write_text = Path.write_text

    def write_text(self, *args, **kwargs):
        if self.name == "SEED.md":  # the disk fills up at the last file
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write_text(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", write_text)
    capsys.readouterr()
    assert cli_main(["seed", "--out", str(out)]) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and "No space left on device" in lines[0]
    assert folder_digest(out) == old and leftovers(tmp_path) == []
