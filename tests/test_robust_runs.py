"""Bounded, recoverable runs: faulty plug-ins become rows, time limits, signals, the matrix-run lock, read-only
commands, and matrix validation that refuses absurd or dangerous input before anything runs.

The faulty plug-ins are fixtures: integrators that hang, call ``sys.exit``, raise ``KeyboardInterrupt``,
return a list as ``nfev`` or a state of the wrong shape, and crash their process with a segfault.
"""

from __future__ import annotations

import fcntl
import importlib
import hashlib
import io
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import psutil
import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.validation import MAX_STEPS
from foucault_bench.bench.run.matrix import MAX_RUNS, load_matrix, parse_matrix
from foucault_bench.bench.run.executors import WORKER_DIED
from foucault_bench.bench.run.runner import run_matrix
from foucault_bench.bench.run.compare import compare_runs
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.integrators import unregister

FAULTY = '''
"""Test-only integrators that misbehave in every way a plug-in can (registered when imported)."""
import ctypes
import sys
from typing import ClassVar

import numpy as np

from foucault_bench.integrators import register
from foucault_bench.integrators.adaptive import AdaptiveIntegrator
from foucault_bench.integrators.base import Solution


class _Base(AdaptiveIntegrator):
    family: ClassVar[str] = "test"
    order: ClassVar[None] = None
    reference: ClassVar[str] = "tests/test_robust_runs.py"


@register
class Hangs(_Base):
    name: ClassVar[str] = "test_hangs"

    def _solve(self, problem, *, step_s, tol, monitor):
        while True:  # a C sleep that holds the GIL (ctypes.PyDLL): only ending the process stops it; no CPU used
            ctypes.PyDLL(None).sleep(3600)


@register
class Exits(_Base):
    name: ClassVar[str] = "test_exits"

    def solve(self, problem, **settings):
        sys.exit(3)

    def _solve(self, problem, *, step_s, tol, monitor):
        raise AssertionError("not reached")


@register
class Interrupts(_Base):
    name: ClassVar[str] = "test_interrupts"

    def solve(self, problem, **settings):
        raise KeyboardInterrupt

    def _solve(self, problem, *, step_s, tol, monitor):
        raise AssertionError("not reached")


@register
class ListAsNfev(_Base):
    name: ClassVar[str] = "test_list_nfev"

    def _solve(self, problem, *, step_s, tol, monitor):
        return Solution(t=problem.t_out, y=np.zeros((problem.t_out.size, 4)), nfev=[1, 2, 3], steps=3)


@register
class WrongShape(_Base):
    name: ClassVar[str] = "test_wrong_shape"

    def _solve(self, problem, *, step_s, tol, monitor):
        return Solution(t=problem.t_out, y=np.zeros((3, 4)), nfev=1, steps=1)


@register
class Segfaults(_Base):
    name: ClassVar[str] = "test_segfaults"

    def _solve(self, problem, *, step_s, tol, monitor):
        ctypes.string_at(0)  # reads address 0: SIGSEGV
'''

FAULTY_INTEGRATORS = ("test_hangs", "test_exits", "test_interrupts", "test_list_nfev", "test_wrong_shape",
                      "test_segfaults")
RUN_TIMEOUT_S = 10.0
"""About 8 times the slowest rk4 or verlet run of seed_2min (1.2 s with a cold compile cache, bench/PERF.md
"matrices", quick cold); the test runs the clean matrix first, so that the faulty one loads compiled code."""

NORMAL = """
scenes = ["seed_2min"]
integrators = ["rk4", "verlet"]
kh = [0.2, 0.1]
[timing]
min_repeats = 1
min_total_s = 0.0
"""


def write(path: Path, text: str) -> Path:
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


@pytest.fixture
def faulty_plugin(tmp_path, monkeypatch):
    """An importable plug-in module (workers get the parent's sys.path) removed again after the test."""
    module_name = f"faulty_integrators_{os.getpid()}"
    write(tmp_path / f"{module_name}.py", FAULTY)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield module_name
    for name in FAULTY_INTEGRATORS:
        unregister(name)
    sys.modules.pop(module_name, None)


def test_faulty_plugins_become_rows_and_normal_rows_are_unchanged(tmp_path, faulty_plugin):
    faulty_matrix = write(tmp_path / "faulty.toml", NORMAL.replace("[timing]", f"""
        plugins = ["{faulty_plugin}"]
        [override.test_hangs]
        tol = [1e-6]
        [override.test_exits]
        tol = [1e-6]
        [override.test_interrupts]
        tol = [1e-6]
        [override.test_list_nfev]
        tol = [1e-6]
        [override.test_wrong_shape]
        tol = [1e-6]
        [override.test_segfaults]
        tol = [1e-6]
        [timing]
        run_timeout_s = {RUN_TIMEOUT_S}""").replace('"rk4", "verlet"', '"rk4", "verlet", ' + ", ".join(
        f'"{name}"' for name in FAULTY_INTEGRATORS)))
    clean_matrix = write(tmp_path / "clean.toml", NORMAL)
    matrix = load_matrix(faulty_matrix)
    assert matrix.run_timeout_s == RUN_TIMEOUT_S
    with ResultsStore(tmp_path / "clean.sqlite") as store:  # first: fills the compile cache the limit excludes
        run_matrix(load_matrix(clean_matrix), store, jobs=2, progress=False)
        clean = store.frame()
    with ResultsStore(tmp_path / "faulty.sqlite") as store:
        run_matrix(matrix, store, jobs=2, progress=False)
        faulty = store.frame()
        provenance = store.matrix_runs().iloc[-1]
    assert provenance["status"] == "finished" and len(faulty) == len(matrix.runs) == 10
    rows = faulty.set_index("integrator")
    assert rows.loc["test_hangs", "status"] == "timeout"
    assert f"time limit of {RUN_TIMEOUT_S:g} s" in rows.loc["test_hangs", "message"]
    assert rows.loc["test_exits", "status"] == "failed"
    assert rows.loc["test_exits", "message"].startswith("solve: SystemExit: 3")
    assert rows.loc["test_interrupts", "status"] == "failed"
    assert rows.loc["test_interrupts", "message"].startswith("solve: KeyboardInterrupt")
    assert rows.loc["test_list_nfev", "status"] == "failed"
    assert "nfev must be a non-negative integer" in rows.loc["test_list_nfev", "message"]
    assert rows.loc["test_wrong_shape", "status"] == "failed"
    assert "shape" in rows.loc["test_wrong_shape", "message"]
    assert rows.loc["test_segfaults", "status"] == "failed"
    assert rows.loc["test_segfaults", "message"] == WORKER_DIED
    normal = faulty[faulty["integrator"].isin(["rk4", "verlet"])]
    assert (normal["status"] == "ok").all(), normal["message"].tolist()
    mismatches, costs, unmatched = compare_runs(clean, normal)
    assert mismatches.empty and not unmatched and len(costs) == len(clean) == 4


# --- validation: refused before anything runs ------------------------------------------------------------------


def refusal(document: dict, tmp_path: Path | None = None) -> list[str]:
    with pytest.raises(InputError) as caught:
        parse_matrix(document, source="m")
    return caught.value.problems


HUGE = 10**400


@pytest.mark.parametrize("document, expected", [
    ({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [HUGE]}, "kh entries must be numbers a float can hold"),
    ({"scene": {"s": {"base": "seed_2min", "length_m": HUGE}}, "integrators": ["rk4"], "kh": [0.1]},
     "length_m must be a finite number"),
    ({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.1], "timing": {"min_repeats": HUGE}},
     "min_repeats must be an integer"),
    ({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.1], "timing": {"run_timeout_s": HUGE}},
     "run_timeout_s must be a finite number of seconds > 0"),
    ({"scenes": ["seed_2min"], "integrators": [], "kh": [0.1]}, "integrators: the list is empty"),
    ({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [1e-9]}, "steps in scene 'seed_2min'"),
    ({"scenes": ["seed_2min"], "integrators": ["cvode_bdf"], "tol": [1e-300]}, "below the double-precision unit"),
    ({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.1], "plugins": ["os"]}, "registers no integrator"),
    ({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.1], "plugins": ["my_package.my_integrator"]},
     "cannot import 'my_package.my_integrator': ModuleNotFoundError"),
])
def test_bad_matrices_are_refused_with_one_line_each(document, expected):
    problems = refusal(document)
    assert any(expected in problem for problem in problems), problems
    assert all("\n" not in problem and len(problem) < 400 for problem in problems)


def test_absurd_step_count_is_refused_with_the_estimate():
    (problem,) = refusal({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [1e-9]})
    estimate = float(problem.split("needs about ")[1].split(" steps")[0])
    assert estimate > MAX_STEPS


def test_plugins_are_imported_only_when_the_rest_is_valid(tmp_path, monkeypatch):
    module_name = f"marker_plugin_{os.getpid()}"
    marker = tmp_path / "imported"
    write(tmp_path / f"{module_name}.py", f"""
        from pathlib import Path
        Path({str(marker)!r}).write_text("the plug-in ran")
        """)
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        problems = refusal({"scenes": ["no_such_scene"], "integrators": ["rk4"], "kh": [0.1], "plugins": [module_name]})
        assert any("unknown scene" in problem for problem in problems)
        assert not marker.exists()
        problems = refusal({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.1], "plugins": [module_name]})
        assert marker.exists() and any("registers no integrator" in problem for problem in problems)
    finally:
        sys.modules.pop(module_name, None)


def test_validation_of_a_long_sweep_finishes(tmp_path):
    values = [0.2 * (1.0 - index / (2 * MAX_RUNS)) for index in range(MAX_RUNS)]
    matrix = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": values})
    assert len(matrix.runs) == len(values) == MAX_RUNS
    with pytest.raises(InputError) as caught:
        parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [*values[:-2], values[7], -1.0]})
    assert len(caught.value.problems) == 2


def test_a_matrix_of_more_than_max_runs_is_refused_before_its_entries_are_read(monkeypatch):
    """A million distinct kh values (the old code validated them for 14 s and 1 GB, then planned a million
    runs): one line giving the count, and no entry is looked at (the per-entry check is never called)."""
    import foucault_bench.bench.run.matrix_runs as matrix_module

    def never(*_):
        raise AssertionError("an entry was validated")

    monkeypatch.setattr(matrix_module, "setting_problem", never)
    values = [0.2 * (1.0 - index / 2e6) for index in range(10**6)]
    (problem,) = refusal({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": values})
    assert f"expands to {10**6} runs" in problem and str(MAX_RUNS) in problem
    # the count is scenes × settings summed over the integrators, each with its own sweep or the shared one
    half = [0.1 * (1.0 - index / 1e6) for index in range(MAX_RUNS // 2 + 1)]
    (problem,) = refusal({"scenes": ["seed_2min"], "integrators": ["rk4", "verlet", "cvode_bdf"], "kh": [0.1],
                          "tol": [1e-6], "override": {"rk4": {"kh": half}, "verlet": {"kh": half}}})
    assert f"expands to {2 * len(half) + 1} runs" in problem


# --- read-only commands --------------------------------------------------------------------------------------


def test_read_only_commands_refuse_a_foreign_database_and_change_nothing(tmp_path, capsys):
    foreign = tmp_path / "other.sqlite"
    with sqlite3.connect(foreign) as connection:
        connection.execute("CREATE TABLE customers (name TEXT)")
        connection.execute("INSERT INTO customers VALUES ('Ada')")
    connection.close()
    before = hashlib.sha256(foreign.read_bytes()).hexdigest()
    for command in (["results", "--db", str(foreign)], ["report", "--db", str(foreign), "--out", str(tmp_path / "r")]):
        assert cli_main(command) == 2
        err = capsys.readouterr().err
        assert "not a foucault-bench results database" in err and "Traceback" not in err
    assert hashlib.sha256(foreign.read_bytes()).hexdigest() == before
    assert sorted(path.name for path in tmp_path.iterdir()) == ["other.sqlite"]  # no -wal, -shm, report folder


# --- signals, kills and the lock: a real matrix run in a subprocess ---------------------------------------------


SLOW = """
scenes = ["seed_2min"]
integrators = ["rk4", "verlet"]
kh = [5e-5, 4.5e-5, 4e-5, 3.5e-5, 3e-5, 2.5e-5, 2e-5, 1.5e-5]  # a few million steps: about 1 s a run with repeats
[timing]
min_repeats = 3
min_total_s = 1.0
"""


def _start(matrix_path: Path, database: Path, *extra: str) -> subprocess.Popen:
    command = [sys.executable, "-m", "foucault_bench.bench.cli", "run", "--matrix", str(matrix_path), "--db",
               str(database), "--jobs", "2", "--no-progress", *extra]
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _workers_started(process: subprocess.Popen, count: int, database: Path, deadline_s: float = 120.0) -> list:
    """The process's descendants once it has ``count`` of them and has stored a row (its matrix run is going)."""
    parent = psutil.Process(process.pid)
    deadline = time.monotonic() + deadline_s
    rows_before = _stored_rows(database)
    while time.monotonic() < deadline and process.poll() is None:
        children = parent.children(recursive=True)
        if len(children) >= count and _stored_rows(database) > rows_before:
            return children
        time.sleep(0.1)
    raise AssertionError(f"the matrix run did not start its workers: {process.stderr.read().decode()[-2000:]}")


def _stored_rows(database: Path) -> int:
    try:
        with sqlite3.connect(f"{database.as_uri()}?mode=ro", uri=True, timeout=5.0) as connection:
            return connection.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    except sqlite3.OperationalError:  # not created yet
        return 0


def _none_survive(processes: list, within_s: float = 10.0) -> list:
    deadline = time.monotonic() + within_s
    alive = processes
    while alive and time.monotonic() < deadline:
        alive = [process for process in alive if process.is_running() and process.status() != psutil.STATUS_ZOMBIE]
        time.sleep(0.2)
    return alive


def test_signals_and_kills_leave_no_process_and_a_second_writer_is_refused(tmp_path, capsys):
    matrix_path = write(tmp_path / "slow.toml", SLOW)
    database = tmp_path / "slow.sqlite"
    process = _start(matrix_path, database)
    try:
        children = _workers_started(process, 2, database)
        # a second writer of the same matrix run: refused at once
        assert cli_main(["run", "--matrix", str(matrix_path), "--db", str(database), "--resume", "--no-progress"]) == 2
        assert "is being written by another process" in capsys.readouterr().err
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=30) == 143
        assert not _none_survive(children)
    finally:
        process.kill()
    with ResultsStore(database, create=False) as store:
        assert store.matrix_runs()["status"].tolist() == ["interrupted"]
    process = _start(matrix_path, database, "--resume")
    try:
        children = _workers_started(process, 2, database)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=30)
        assert not _none_survive(children)
    finally:
        process.kill()
    process = _start(matrix_path, database, "--resume")
    try:
        children = _workers_started(process, 2, database)
        process.send_signal(signal.SIGINT)
        time.sleep(0.01)
        process.send_signal(signal.SIGINT)  # while the first is being handled: everything ends at once
        assert process.wait(timeout=30) == 130
        assert not _none_survive(children)
    finally:
        process.kill()


def test_a_task_past_its_time_limit_has_its_process_killed():
    """What a Dask task does (``run_isolated``), here outside Dask: the worker process is killed at the limit
    and the next task gets a fresh one that checks its code version first."""
    from foucault_bench.bench.run import dask_executor
    from foucault_bench.bench.run.matrix import code_version

    def on_failure(*task, status, reason):
        return status, reason

    status, reason = dask_executor.run_isolated(time.sleep, (60,), 1.0, on_failure, code_version(()), ())
    assert status == "timeout" and "time limit of 1 s" in reason
    assert dask_executor._THREAD.worker is None  # killed, not kept
    assert dask_executor.run_isolated(sum, ((1, 2),), 30.0, on_failure, code_version(()), ()) == 3
    worker = dask_executor._THREAD.worker
    with pytest.raises(dask_executor.CodeMismatch):
        dask_executor.run_isolated(sum, ((1, 2),), 30.0, on_failure, "another version", ())
    worker.close()
    assert not worker.alive()


def test_a_closed_output_pipe_ends_quietly(tmp_path):
    """``results ... | head -n 1``: the reader closes the pipe after one line, the command ends with 141 and no
    traceback. For the command to meet the closed pipe, its output must not fit in the pipe: a pipe holds 64 KiB on
    Linux and the reader's ``readline`` takes up to 8 KiB more, and output that fits (400 short rows were 46 kB)
    may all be written, and the command end with 0, before the reader closes its end. Each row's message makes the
    output 4 times that; the command then blocks on the full pipe until the reader has closed it, whatever the
    scheduling."""
    message = "m" * 750  # 400 rows: 300 kB of messages alone
    matrix = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"],
                           "kh": [0.2 * 0.999**index for index in range(400)]})
    database = tmp_path / "many.sqlite"
    with ResultsStore(database) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        for spec in matrix.runs:
            store.write_run({"run_key": spec.run_key, "matrix_id": matrix_id, "scene": spec.scene.name,
                             "integrator": spec.integrator, "kh": spec.kh, "status": "ok", "message": message})
        store.finish_matrix_run(matrix_id)
    process = subprocess.Popen([sys.executable, "-m", "foucault_bench.bench.cli", "results", "--db", str(database),
                                "--all", "--csv", "/dev/stdout"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    pipe_capacity = fcntl.fcntl(process.stdout, fcntl.F_GETPIPE_SZ) if hasattr(fcntl, "F_GETPIPE_SZ") else 65536
    assert len(matrix.runs) * len(message) > 4 * (pipe_capacity + io.DEFAULT_BUFFER_SIZE)
    assert process.stdout.readline().startswith(b"run_key")
    process.stdout.close()  # like `| head -n 1`
    assert process.wait(timeout=60) == 128 + signal.SIGPIPE
    assert b"Traceback" not in process.stderr.read()


# --- command options: checked before any work ---------------------------------------------------------------


def test_bad_output_paths_and_options_are_refused_before_any_work(tmp_path, capsys):
    regular = tmp_path / "a_file"
    regular.write_text("not a folder")
    missing = tmp_path / "no_such_folder"
    cases = [
        (["run", "--matrix", "quick", "--db", str(regular / "x.sqlite")], "--db"),
        (["run", "--matrix", "quick", "--db", str(tmp_path)], "is a folder"),
        (["run", "--matrix", "quick", "--run-timeout", "-1"], "--run-timeout must be a finite number"),
        (["run", "--matrix", "quick", "--run-timeout", "inf"], "--run-timeout must be a finite number"),
        (["results", "--db", str(tmp_path / "none.sqlite"), "--csv", str(missing / "rows.csv")],
         f"the folder {missing} does not exist"),
        (["results", "--db", str(tmp_path / "none.sqlite"), "--parquet", str(regular / "rows.parquet")],
         "is not a folder"),
        (["check", "--thresholds", "default", "--junit", str(missing / "junit.xml")],
         f"the folder {missing} does not exist"),
        (["report", "--db", str(tmp_path / "none.sqlite"), "--out", str(regular)], "exists and is not a folder"),
    ]
    for command, expected in cases:
        assert cli_main(command) == 2, command
        err = capsys.readouterr().err
        assert expected in err and "Traceback" not in err, (command, err)
        assert len([line for line in err.splitlines() if "error:" in line]) == 1
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a_file"]  # nothing created


def test_a_run_timeout_the_executors_cannot_wait_is_refused_before_anything_is_opened(tmp_path, capsys):
    """--run-timeout 3e6 s passed validation, opened the matrix run and then raised OverflowError in the local
    executor's wait (poll(2) takes a C int of milliseconds), leaving the run "interrupted". Now: exit 2, one
    line, no database; and the documented maximum is one the wait accepts, a little more than the overflow
    point is not."""
    import multiprocessing
    import multiprocessing.connection

    from foucault_bench.bench.validation import MAX_RUN_TIMEOUT_S

    matrix = write(tmp_path / "tiny.toml", 'scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [0.2]\n')
    database = tmp_path / "results.sqlite"
    for flag, value in (("--run-timeout", "3e6"), ("--run-timeout", str(MAX_RUN_TIMEOUT_S * 1.5))):
        assert cli_main(["run", "--matrix", str(matrix), "--db", str(database), flag, value, "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1
        assert f"--run-timeout = {float(value):g} s is more than 1e+06 s" in err
        assert not database.exists()
    (problem,) = refusal({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.2],
                          "timing": {"run_timeout_s": 3e6}})
    assert "timing: run_timeout_s = 3e+06 s is more than 1e+06 s" in problem
    ready, other_end = multiprocessing.Pipe()
    other_end.send(b"x")  # so that the wait returns at once
    assert multiprocessing.connection.wait([ready], timeout=MAX_RUN_TIMEOUT_S) == [ready]
    with pytest.raises(OverflowError):
        multiprocessing.connection.wait([ready], timeout=(2**31 + 1000) / 1000)


def test_more_jobs_than_cores_are_capped_with_a_note(capsys):
    from foucault_bench.bench.commands.options import jobs
    from foucault_bench.bench.provenance import available_cores

    assert jobs(10_000) == available_cores()
    assert f"--jobs 10000 is more than the {available_cores()} core(s) available" in capsys.readouterr().err
    assert jobs(1) == 1
    with pytest.raises(InputError):
        jobs(0)


def test_a_run_time_limit_counts_from_the_start_of_the_run_not_of_its_worker(tmp_path, monkeypatch):
    """A worker's start-up (here: a task module that takes 2 s to import, as heavy imports do on a loaded machine)
    is not the run's time: a 1 s limit stops a run that takes 60 s, not an instant one behind a slow start."""
    from foucault_bench.bench.run.local_executor import LocalExecutor

    module_name = f"slow_to_import_{os.getpid()}"
    write(tmp_path / f"{module_name}.py", """
        import time
        time.sleep(2.0)

        def echo(value):
            return value
    """)
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module(module_name)  # the parent imports it once; a fresh worker pays the 2 s

    def on_failure(*task, status, reason):
        return status

    executor = LocalExecutor(jobs=1)
    try:
        assert [value for _, value in executor.map_unordered(module.echo, [("answer",)], on_failure, 1.0)] == ["answer"]
        assert [value for _, value in executor.map_unordered(time.sleep, [(60,)], on_failure, 1.0)] == ["timeout"]
    finally:
        executor.kill()
        sys.modules.pop(module_name, None)
