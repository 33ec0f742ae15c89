"""Dask: the same matrix on a cluster gives the same accuracy columns as a local run, bit for bit; losing the
scheduler interrupts the matrix run and ``--resume`` completes it; workers running other code are not used;
addresses that are not a Dask scheduler are refused within a bounded time.

The clusters are real: a scheduler and single-threaded workers started as subprocesses on the loopback
interface only, bounded in time, and stopped by the tests (marked ``dask``: ``pytest -m dask``).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import foucault_bench.bench.run.dask_executor as executors_module

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.bench.run.runner import make_executor, run_matrix
from foucault_bench.bench.run.compare import compare_runs
from foucault_bench.bench.run.store import ResultsStore

pytestmark = pytest.mark.dask

STARTUP_TIMEOUT_S = 60.0

TINY = """
scenes = ["seed_2min"]
integrators = ["rk4", "verlet", "explicit_euler", "heyoka_taylor", "cvode_adams", "scipy_dop853"]
kh = [0.2, 0.1]
tol = [1e-6, 1e-9]
[override.explicit_euler]
kh = [0.1]
[timing]
min_repeats = 1
min_total_s = 0.0
"""


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=15)


def start_cluster(directory: Path, workers: int) -> tuple[str, list[subprocess.Popen]]:
    """A scheduler (127.0.0.1, free port) and ``workers`` worker processes of one thread each; returns its
    address and the processes (the scheduler first)."""
    directory.mkdir(parents=True, exist_ok=True)
    scheduler_file = directory / "scheduler.json"
    processes = [subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
         "--no-dashboard", "--scheduler-file", str(scheduler_file)],
        cwd=directory, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        processes.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", address, "--host", "127.0.0.1",
             "--nthreads", "1", "--nworkers", str(workers), "--no-dashboard", "--memory-limit", "0",
             "--death-timeout", "60", "--local-directory", str(directory)],
            cwd=directory, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client

        with Client(address, timeout=f"{STARTUP_TIMEOUT_S}s") as client:
            client.wait_for_workers(workers, timeout=STARTUP_TIMEOUT_S)
    except BaseException:
        stop_cluster(processes)
        raise
    return address, processes


def stop_cluster(processes: list[subprocess.Popen]) -> None:
    for process in reversed(processes):
        _stop(process)


@pytest.fixture(scope="module")
def dask_scheduler(tmp_path_factory):
    """Address of a local scheduler with one worker of one thread."""
    address, processes = start_cluster(tmp_path_factory.mktemp("dask"), workers=1)
    try:
        yield address
    finally:
        stop_cluster(processes)


def test_dask_and_local_runs_agree_bit_for_bit(tmp_path, dask_scheduler, capsys):
    matrix_path = tmp_path / "tiny.toml"
    matrix_path.write_text(textwrap.dedent(TINY), encoding="utf-8")
    matrix = load_matrix(matrix_path)
    database = tmp_path / "dask.sqlite"
    with ResultsStore(database) as store:
        local_id = run_matrix(matrix, store, jobs=1, progress=False)
    assert cli_main(["run", "--matrix", str(matrix_path), "--db", str(database), "--scheduler", dask_scheduler,
                     "--no-progress"]) == 0
    with ResultsStore(database) as store:
        dask_id = store.resolve_matrix_id(None)
        local, remote = store.frame(local_id), store.frame(dask_id)
        provenance = store.matrix_runs().set_index("matrix_id")
    assert dask_id != local_id and provenance.loc[dask_id, "scheduler"] == dask_scheduler
    assert len(local) == len(remote) == len(matrix.runs)
    assert (local["status"] == "ok").all(), local["message"].tolist()
    mismatches, costs, unmatched = compare_runs(local, remote)
    assert mismatches.empty, mismatches.to_string()
    assert not unmatched
    capsys.readouterr()
    assert cli_main(["results", "--db", str(database), "--compare", local_id, dask_id]) == 0
    assert "identical bit for bit" in capsys.readouterr().out


def test_an_unreachable_scheduler_is_an_input_error(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(executors_module, "DASK_CONNECT_TIMEOUT_S", 1.0)  # nothing listens on the discard port
    matrix_path = tmp_path / "tiny.toml"
    matrix_path.write_text(textwrap.dedent(TINY), encoding="utf-8")
    database = tmp_path / "none.sqlite"
    status = cli_main(["run", "--matrix", str(matrix_path), "--db", str(database),
                       "--scheduler", "tcp://127.0.0.1:9", "--no-progress"])
    err = capsys.readouterr().err
    assert status == 2 and "cannot connect to the Dask scheduler" in err and "Traceback" not in err
    assert not Path(database).exists()


def test_a_silent_service_or_tls_without_settings_is_refused_in_bounded_time(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(executors_module, "DASK_CONNECT_TIMEOUT_S", 2.0)
    matrix_path = tmp_path / "tiny.toml"
    matrix_path.write_text(textwrap.dedent(TINY), encoding="utf-8")
    with socket.socket() as silent:  # accepts connections and never answers
        silent.bind(("127.0.0.1", 0))
        silent.listen()
        port = silent.getsockname()[1]
        for address, expected in [(f"tcp://127.0.0.1:{port}", "cannot connect to the Dask scheduler: no answer within 2 s"),
                                  (f"tls://127.0.0.1:{port}", "needs TLS settings"),
                                  ("tcp://nonsense:::x", "not a Dask scheduler address")]:
            started = time.monotonic()
            status = cli_main(["run", "--matrix", str(matrix_path), "--db", str(tmp_path / "x.sqlite"),
                               "--scheduler", address, "--no-progress"])
            err = capsys.readouterr().err
            assert status == 2 and expected in err and "Traceback" not in err, err
            assert [line for line in err.splitlines() if "error:" in line] == [err.splitlines()[-1]]
            assert time.monotonic() - started < 30.0  # bounded: the probe's 2 s, not forever
    assert not (tmp_path / "x.sqlite").exists()


def test_workers_running_other_code_are_not_used(tmp_path, dask_scheduler, capsys, monkeypatch):
    """A plug-in only the client can import: the worker's code version differs, so no worker is usable."""
    module_name = f"client_only_plugin_{os.getpid()}"
    (tmp_path / f"{module_name}.py").write_text(textwrap.dedent("""
        from typing import ClassVar
        from foucault_bench.integrators import register
        from foucault_bench.integrators.methods.rk4 import RK4

        @register
        class ClientOnly(RK4):
            name: ClassVar[str] = "client_only_rk4"
        """), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    matrix_path = tmp_path / "plugin.toml"
    matrix_path.write_text(f'plugins = ["{module_name}"]\nscenes = ["seed_2min"]\nintegrators = ["client_only_rk4"]\n'
                           "kh = [0.2]\n", encoding="utf-8")
    try:
        status = cli_main(["run", "--matrix", str(matrix_path), "--db", str(tmp_path / "p.sqlite"),
                           "--scheduler", dask_scheduler, "--no-progress"])
    finally:
        from foucault_bench.integrators import unregister

        unregister("client_only_rk4")
        sys.modules.pop(module_name, None)
    err = capsys.readouterr().err
    assert status == 2 and "no Dask worker runs this client's code" in err and "is not used" in err
    assert not (tmp_path / "p.sqlite").exists() or _rows(tmp_path / "p.sqlite") == 0


SLOWER = """
scenes = ["seed_2min"]
integrators = ["rk4", "verlet"]
kh = [4e-5, 3e-5, 2e-5, 1.5e-5]  # a few million steps: at least half a second a run with its repeats, so that
[timing]                          # six runs (3 s of CPU) remain when the test ends the scheduler after two rows
min_repeats = 3
min_total_s = 0.5
"""


def _rows(database: Path) -> int:
    try:
        with sqlite3.connect(f"{database.as_uri()}?mode=ro", uri=True, timeout=5.0) as connection:
            return connection.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    except sqlite3.OperationalError:
        return 0


def test_losing_the_scheduler_interrupts_and_resume_completes(tmp_path):
    matrix_path = tmp_path / "slower.toml"
    matrix_path.write_text(textwrap.dedent(SLOWER), encoding="utf-8")
    matrix = load_matrix(matrix_path)
    database = tmp_path / "cluster.sqlite"
    address, processes = start_cluster(tmp_path / "first", workers=2)
    try:
        client = subprocess.Popen(
            [sys.executable, "-m", "foucault_bench.bench.cli", "run", "--matrix", str(matrix_path), "--db",
             str(database), "--scheduler", address, "--no-progress"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.monotonic() + 120.0
        while _rows(database) < 2 and client.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        processes[0].send_signal(signal.SIGKILL)  # the scheduler, mid-matrix
        assert client.wait(timeout=60) == 75
        message = client.stderr.read().decode()
        assert "interrupted: lost the connection to the Dask scheduler" in message, message
    finally:
        client.kill()
        stop_cluster(processes)
    with ResultsStore(database, create=False) as store:
        assert store.matrix_runs()["status"].tolist() == ["interrupted"]
        before = store.frame()
    assert 2 <= len(before) < len(matrix.runs)
    assert (before["status"] == "ok").all()  # nothing stored as failed for the cluster's reason
    address, processes = start_cluster(tmp_path / "second", workers=2)
    try:
        assert cli_main(["run", "--matrix", str(matrix_path), "--db", str(database), "--scheduler", address,
                         "--resume", "--no-progress"]) == 0
    finally:
        stop_cluster(processes)
    with ResultsStore(database) as store:
        runs = store.matrix_runs()
        resumed = store.frame()
        local_id = run_matrix(matrix, store, jobs=2, progress=False)
        local = store.frame(local_id)
    assert runs["status"].tolist() == ["finished"] and len(resumed) == len(matrix.runs)
    mismatches, costs, unmatched = compare_runs(local, resumed)
    assert mismatches.empty and not unmatched and len(costs) == len(matrix.runs)


def test_losing_every_worker_interrupts(tmp_path, monkeypatch):
    import threading

    import psutil

    from foucault_bench.bench.errors import RunInterrupted

    monkeypatch.setattr(executors_module, "WORKERS_GONE_S", 3.0)
    matrix_path = tmp_path / "slower.toml"
    matrix_path.write_text(textwrap.dedent(SLOWER), encoding="utf-8")
    matrix = load_matrix(matrix_path)
    database = tmp_path / "workers.sqlite"
    address, processes = start_cluster(tmp_path / "cluster", workers=1)

    def kill_the_workers() -> None:
        deadline = time.monotonic() + 120.0
        while _rows(database) < 1 and time.monotonic() < deadline:
            time.sleep(0.1)
        tree = psutil.Process(processes[1].pid)
        for process in [*tree.children(recursive=True), tree]:
            process.kill()

    killer = threading.Thread(target=kill_the_workers, daemon=True)
    try:
        executor = make_executor(1, address)
        with ResultsStore(database) as store:
            killer.start()
            with pytest.raises(RunInterrupted, match="every usable Dask worker"):
                run_matrix(matrix, store, executor=executor, progress=False)
            assert store.matrix_runs()["status"].tolist() == ["interrupted"]
            rows = store.frame()
        assert 1 <= len(rows) < len(matrix.runs) and (rows["status"] == "ok").all()
    finally:
        killer.join(timeout=130)
        stop_cluster(processes)
