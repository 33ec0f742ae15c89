"""numba's disk cache shared by processes compiling at the same time (``models.jit``, "Compiled once per machine").

* two processes that need the same function at the same moment compile it once: one compiles (with the
  functions it calls), the other waits for the entry's lock and loads that code, and both compute the same
  numbers bit for bit (the ``FOUCAULT_BENCH_JIT_LOG`` lines tell which process did what);
* a lock whose holder was killed does not keep anyone waiting (the operating system releases an ``flock``).
"""

from __future__ import annotations

import fcntl
import os
import signal
import subprocess
import sys

import pytest

RACE_SCRIPT = """
import sys
from foucault_bench.models import MODELS
energy = MODELS["spherical"].numba_energy
print("ready", flush=True)
sys.stdin.readline()  # both processes start compiling when the test says so
parameters = tuple(1.0 + 0.1 * i for i in range(13))
print(float.hex(energy(0.3, -0.2, 0.01, 0.02, parameters)), flush=True)
"""


def test_two_processes_compile_a_function_once_and_compute_the_same_numbers(tmp_path) -> None:
    log = tmp_path / "jit.log"
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "FOUCAULT_BENCH_JIT_LOG": str(log)}
    processes = [subprocess.Popen([sys.executable, "-c", RACE_SCRIPT], env=environment, text=True,
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE) for _ in range(2)]
    for process in processes:
        assert process.stdout.readline() == "ready\n"  # both imported, nothing compiled yet
    for process in processes:
        process.stdin.write("go\n")
        process.stdin.flush()
    energies = [process.communicate()[0].strip() for process in processes]
    assert [process.returncode for process in processes] == [0, 0]
    assert energies[0] == energies[1] and float.fromhex(energies[0]) != 0.0

    lines = [line.split("\t") for line in log.read_text().splitlines()]
    by_process: dict[str, dict[str, list[str]]] = {}
    for pid, _, outcome, _, _, _, name, signature in lines:
        by_process.setdefault(pid, {}).setdefault(outcome, []).append(f"{name} {signature}")
    assert len(by_process) == 2
    compiler, loader = sorted(by_process.values(), key=lambda outcomes: len(outcomes.get("compiled", [])))[::-1]
    # the compiler built the energy and the model function it calls; the loader compiled nothing
    assert list(compiler) == ["compiled"] and len(compiler["compiled"]) >= 2
    assert list(loader) == ["loaded"] and len(loader["loaded"]) == 1
    top = loader["loaded"][0]
    assert top.startswith("Model.numba_energy.") and top in compiler["compiled"]
    assert len(set(compiler["compiled"])) == len(compiler["compiled"])  # nothing compiled twice


HOLDER_SCRIPT = """
import sys, time
from foucault_bench.models.jit import built_once
with built_once(lambda: sys.argv[1]):
    print("locked", flush=True)
    time.sleep(600)
"""


def test_an_entry_lock_is_held_while_its_holder_lives_and_free_once_it_is_killed(tmp_path) -> None:
    path = tmp_path / "entry.lock"
    holder = subprocess.Popen([sys.executable, "-c", HOLDER_SCRIPT, str(path)], text=True, stdout=subprocess.PIPE)
    try:
        assert holder.stdout.readline() == "locked\n"
        with open(path) as lock, pytest.raises(BlockingIOError):
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    with open(path) as lock:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)  # raises BlockingIOError if the lock outlived its holder
