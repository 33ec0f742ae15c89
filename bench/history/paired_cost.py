"""Paired timing: two (or more) code versions' solves alternated in one session, so that both see the same machine.

Costs measured at different times differ by more than their repeats' scatter on a shared machine (bench/PERF.md
"Cost changes across revisions": the adaptive drivers shift by 5-30 % between rounds while their repeats scatter
by 10 %). Here each *side* (a code version: a source folder or the installed package, plus plug-in modules to
import) gets a worker process; for each run of a matrix every worker makes one untimed warm-up solve and then
the workers take turns, one timed solve each per *cycle* (the side that starts a cycle rotates, so no side
always runs first), ``cycles`` times. Only one worker computes at any moment and the solves of one cycle are
adjacent in time, so whatever the machine does (a neighbour on the sibling vCPU, the load of other jobs)
reaches the sides of a cycle alike; the ratio within each cycle is the comparison
(``bench.history.changes.paired_cost_change``). The whole matrix is timed ``process_sets`` times, each time by
fresh workers, so that what belongs to one process (code placement, memory layout) is averaged over
(measured in bench/PERF.md: two same-code workers' ratio per set of processes was within ± 1.6 % in 18 of 20
sets, the others at 0.94 and 0.97).

A worker (``WORKER_CODE``, run as ``python -c``) imports the side's code (a source folder is put first on the
import path with the installed package's finder removed, as ``bench.history.bisect`` does), loads the matrix with
that code's ``load_matrix``, prints what its runs are (one JSON line: scene, integrator, kh, tol and run key each)
and answers one line per command on stdin: ``warm I`` (the I-th run's solve, untimed; it answers its status) and
``time I`` (one solve; it answers the CPU time of the worker thread, ``time.thread_time``, as ``repr`` of a float).
Its native thread pools are capped at one thread (``bench.run.timing.limit_threads``).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from foucault_bench.bench.errors import InputError

WORKER_CODE = """
import json, sys, time
source, matrix_path, plugins = sys.argv[1], sys.argv[2], [name for name in sys.argv[3].split(",") if name]
if source:
    sys.path.insert(0, source)
    sys.meta_path[:] = [finder for finder in sys.meta_path if "editable" not in repr(finder).lower()]
from foucault_bench.bench.run.timing import limit_threads
limit_threads()
import foucault_bench.bench.cli as cli
if source and not cli.__file__.startswith(source):
    sys.exit("paired timing: imported " + cli.__file__ + " instead of " + source)
import importlib
for name in plugins:
    importlib.import_module(name)
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.integrators import get_integrator
runs = load_matrix(matrix_path).runs
solves = {}
def solve(index):
    if index not in solves:
        spec = runs[index]
        integrator, problem = get_integrator(spec.integrator), spec.scene.problem()
        solves[index] = lambda: integrator.solve(problem, step_s=spec.step_s, tol=spec.tol, monitor=False)
    return solves[index]()
print(json.dumps([[spec.scene.name, spec.integrator, spec.kh, spec.tol, spec.run_key] for spec in runs]), flush=True)
for line in sys.stdin:
    command, index = line.split()
    if command == "warm":
        print(solve(int(index)).status, flush=True)
    else:
        start = time.thread_time()
        solve(int(index))
        print(repr(time.thread_time() - start), flush=True)
"""


@dataclass(frozen=True)
class Side:
    """One code version of a paired comparison: its label, its source folder (the directory holding the
    ``foucault_bench`` package; None: the installed package) and plug-in modules its workers import."""

    label: str
    source: Path | None = None
    plugins: tuple[str, ...] = ()


class TimingWorker:
    """One side's worker process for one run (module docstring); ``close`` ends it."""

    def __init__(self, side: Side, matrix_path: Path):
        self.side = side
        self.errors = tempfile.TemporaryFile(mode="w+")  # a file, not a pipe: a chatty worker cannot block on it
        self.process = subprocess.Popen(
            [sys.executable, "-c", WORKER_CODE, str(side.source or ""), str(matrix_path), ",".join(side.plugins)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.errors, text=True)
        self.runs: list[list] = json.loads(self._answer())
        """What each run of the matrix is, as this side's code reads it: scene, integrator, kh, tol, and the
        run key (which also hashes the code version, so it differs between code versions)."""

    def _answer(self) -> str:
        assert self.process.stdout is not None
        line = self.process.stdout.readline()
        if not line:
            self.process.wait()
            self.errors.seek(0)
            error = self.errors.read().strip().splitlines()
            raise InputError(f"paired timing, side {self.side.label}: its worker ended"
                             + (f": {error[-1]}" if error else ""))
        return line.strip()

    def ask(self, command: str, index: int) -> str:
        assert self.process.stdin is not None
        self.process.stdin.write(f"{command} {index}\n")
        self.process.stdin.flush()
        return self._answer()

    def close(self) -> None:
        if self.process.stdin is not None:
            self.process.stdin.close()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.errors.close()


def cycle_order(sides: int, cycle: int) -> list[int]:
    """The order in which the sides time their solve in cycle ``cycle``: rotated by one each cycle."""
    return [(cycle + offset) % sides for offset in range(sides)]


def paired_times(matrix_path: Path, sides: Sequence[Side], *, cycles: int, process_sets: int = 1,
                 progress: Callable[[str], None] = lambda line: None
                 ) -> tuple[dict[str, list[list]], dict[int, dict[str, list[float]]]]:
    """Side label → what each run of the matrix is (``TimingWorker.runs``), and run index → side label → CPU
    times (s) of its ``cycles × process_sets`` timed solves in cycle order (module docstring): ``process_sets``
    times a fresh worker per side, each making ``cycles`` cycles of every run. Runs whose warm-up is not ``ok``
    on every side are left out. ``progress`` gets a line per run timed. ``InputError`` when a side's worker
    cannot load its code or the matrix, or the sides read other runs from it (scene, integrator, setting)."""
    if len(sides) < 2 or cycles < 1 or process_sets < 1:
        raise InputError("paired timing needs two sides or more, at least one cycle and one process set")
    times: dict[int, dict[str, list[float]]] = {}
    identities: dict[str, list[list]] = {}
    failed: set[int] = set()
    for process_set in range(process_sets):
        workers = [TimingWorker(side, matrix_path) for side in sides]
        try:
            if any([run[:4] for run in worker.runs] != [run[:4] for run in workers[0].runs] for worker in workers):
                raise InputError("paired timing: the sides' code reads other runs from the matrix "
                                 f"({', '.join(f'{worker.side.label}: {len(worker.runs)}' for worker in workers)})")
            identities = {worker.side.label: worker.runs for worker in workers}
            for index in range(len(workers[0].runs)):
                if index in failed or not all(worker.ask("warm", index) == "ok" for worker in workers):
                    failed.add(index)
                    times.pop(index, None)
                    continue
                samples = times.setdefault(index, {side.label: [] for side in sides})
                for cycle in range(cycles):
                    for position in cycle_order(len(sides), cycle):
                        samples[sides[position].label].append(float(workers[position].ask("time", index)))
                progress(f"process set {process_set + 1}, run {index}: " + ", ".join(
                    f"{label} {sorted(values)[len(values) // 2] * 1e3:.1f} ms" for label, values in samples.items()))
        finally:
            for worker in workers:
                worker.close()
    return identities, times
