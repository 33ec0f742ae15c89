"""The same matrix on a Dask distributed cluster gives the same accuracy columns as a local run, bit for bit.

The cluster is real: a scheduler and one single-threaded worker started as subprocesses on the loopback
interface only, bounded in time, and stopped by the fixture.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import foucault_bench.bench.run.runner as runner_module

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.bench.run.runner import run_matrix
from foucault_bench.bench.run.store import ResultsStore, compare_runs

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


@pytest.fixture(scope="module")
def dask_scheduler(tmp_path_factory):
    """Address of a local scheduler (127.0.0.1, free port) with one worker of one thread."""
    directory = tmp_path_factory.mktemp("dask")
    scheduler_file = directory / "scheduler.json"
    processes = []
    try:
        processes.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
             "--no-dashboard", "--scheduler-file", str(scheduler_file)],
            cwd=directory, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        processes.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", address, "--host", "127.0.0.1",
             "--nthreads", "1", "--nworkers", "1", "--no-dashboard", "--memory-limit", "0",
             "--death-timeout", "60", "--local-directory", str(directory)],
            cwd=directory, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client

        with Client(address, timeout=f"{STARTUP_TIMEOUT_S}s") as client:
            client.wait_for_workers(1, timeout=STARTUP_TIMEOUT_S)
        yield address
    finally:
        for process in reversed(processes):
            _stop(process)


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
    monkeypatch.setattr(runner_module, "DASK_CONNECT_TIMEOUT_S", 1.0)  # nothing listens on the discard port
    matrix_path = tmp_path / "tiny.toml"
    matrix_path.write_text(textwrap.dedent(TINY), encoding="utf-8")
    database = tmp_path / "none.sqlite"
    status = cli_main(["run", "--matrix", str(matrix_path), "--db", str(database),
                       "--scheduler", "tcp://127.0.0.1:9", "--no-progress"])
    err = capsys.readouterr().err
    assert status == 2 and "cannot connect to the Dask scheduler" in err and "Traceback" not in err
    assert not Path(database).exists()
