"""Section ``startup``: how fast the command line starts, and where a small matrix's time goes.

* ``foucault-bench --help`` and every command's ``--help``: wall time of the whole process, median of
  ``REPEATS`` (target ≤ 0.3 s each: parsing imports no numerical library, ``bench.commands``);
* ``SMALL_MATRIX`` (5 runs: two fixed-step, three adaptive, on the 2-minute seed scene) with ``foucault-bench run
  --jobs 1`` on warm caches (one untimed run first fills the numba, heyoka and reference caches): median wall
  time of ``REPEATS`` runs (target ≤ 3 s);
* the same matrix taken apart in one fresh interpreter (``probe``): each piece timed where it runs — the
  imports of the main process, the matrix validation, the references and model adequacy and the runs (the work
  of a worker, which pays the same imports again in its own interpreter), the store (open, provenance, writes)
  and the summary. Medians of ``REPEATS`` fresh interpreters.

The command line is the layer above ``bench``: this section runs it as a user does, in a subprocess, and loads
it by its module name (``CLI_MODULE``, ``COMMANDS_MODULE``, as ``python -m`` does) where it times the import in
this interpreter, so that the harness depends on nothing of it at import time.
"""

from __future__ import annotations

import importlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from foucault_bench.bench.perf.measure import Row, run_timed

SECTION = "startup"
TARGET_HELP_S = 0.3
TARGET_SMALL_MATRIX_S = 3.0
REPEATS = 5
SMALL_MATRIX = """
name = "startup_small"
description = "5 runs on the 2-minute seed scene: how long a small matrix takes from the command line"
scenes = ["seed_2min"]
integrators = ["rk4", "verlet", "heyoka_taylor", "cvode_bdf", "scipy_dop853"]
kh = [0.1]
tol = [1e-8]

[timing]
min_repeats = 1
max_total_s = 0.05
max_repeats = 3
"""
CLI_MODULE = "foucault_bench.bench.cli"
COMMANDS_MODULE = "foucault_bench.bench.commands"
PIECES = ("command-line module", "imports of the runner, matrix and store", "matrix validation",
          "references (warm cache) and model adequacy", "integration and verdicts (5 runs)",
          "store: open, provenance, writes", "summary")
"""The pieces ``probe`` times, in order; a worker pays the first two again in its own interpreter."""


def _cli(*arguments: str) -> list[str]:
    return [sys.executable, "-m", CLI_MODULE, *arguments]


def _median_wall(command: list[str], repeats: int) -> tuple[float, list[float]]:
    walls = []
    for _ in range(repeats):
        wall_s, done = run_timed(command)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr.strip()[-2000:]}")
        walls.append(wall_s)
    return statistics.median(walls), walls


def probe(matrix_path: str) -> dict[str, float]:
    """The pieces of a ``run`` of the matrix, in this (fresh) interpreter, one after the other (s)."""
    marks = [time.perf_counter()]
    importlib.import_module(CLI_MODULE)  # what every command pays

    marks.append(time.perf_counter())
    from foucault_bench.bench.run import execute, runner  # noqa: F401 - runner: its import is what is measured
    from foucault_bench.bench.run.matrix import load_matrix
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.run.summary import summary_text

    marks.append(time.perf_counter())
    matrix = load_matrix(matrix_path)
    marks.append(time.perf_counter())
    for scene in matrix.scenes:
        execute.prepare_scene(scene)
    marks.append(time.perf_counter())
    rows = [execute.execute_run(spec, "probe") for spec in matrix.runs]
    marks.append(time.perf_counter())
    with tempfile.TemporaryDirectory(prefix="foucault-perf-startup-") as directory:
        with ResultsStore(Path(directory) / "probe.sqlite") as store:
            matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
            for row in rows:
                store.write_run({**row, "matrix_id": matrix_id})
            marks.append(time.perf_counter())
            summary_text(store.records(matrix_id))
            marks.append(time.perf_counter())
    return {piece: end - start for piece, start, end in zip(PIECES, marks[:-1], marks[1:], strict=True)}


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Help times, the small matrix's wall time and its pieces; the rows, a detail table and its headers."""
    repeats = 3 if quick else REPEATS
    rows, table = [], []
    commands = importlib.import_module(COMMANDS_MODULE).COMMANDS
    for command in ("", *commands):
        median_s, walls = _median_wall(_cli(*filter(None, [command]), "--help"), repeats)
        rows.append(Row(SECTION, f"foucault-bench {command + ' ' if command else ''}--help", median_s, "s",
                        TARGET_HELP_S, f"median of {repeats}; max {max(walls):.2f} s"))
    interpreter_s, _ = _median_wall([sys.executable, "-c", "pass"], repeats)
    with tempfile.TemporaryDirectory(prefix="foucault-perf-startup-") as directory:
        matrix_path = Path(directory) / "startup_small.toml"
        matrix_path.write_text(SMALL_MATRIX, encoding="utf-8")
        run_command = _cli("run", "--matrix", str(matrix_path), "--jobs", "1", "--no-progress",
                           "--db", str(Path(directory) / "runs.sqlite"))
        _median_wall(run_command, 1)  # fills the caches
        median_s, walls = _median_wall(run_command, repeats)
        load = ", ".join(f"{value:.1f}" for value in os.getloadavg()) if hasattr(os, "getloadavg") else "?"
        rows.append(Row(SECTION, "5-run matrix, warm caches, run --jobs 1: wall time", median_s, "s",
                        TARGET_SMALL_MATRIX_S, f"median of {repeats}: {', '.join(f'{wall:.2f}' for wall in walls)} s; "
                        f"load {load}"))
        probes = []
        for _ in range(repeats):
            done = subprocess.run([sys.executable, "-m", "foucault_bench.bench.perf.startup", str(matrix_path)],
                                  capture_output=True, text=True, check=True)
            probes.append(json.loads(done.stdout.strip().splitlines()[-1]))
    pieces = {"interpreter start": interpreter_s}
    pieces |= {piece: statistics.median(probe[piece] for probe in probes) for piece in PIECES}
    for piece, seconds in pieces.items():
        table.append([piece, f"{seconds:.3f}", f"{100 * seconds / sum(pieces.values()):.0f} %"])
    table.append(["sum (one process doing everything in turn)", f"{sum(pieces.values()):.3f}", "100 %"])
    return rows, table, ["piece of a 5-run matrix (median of fresh interpreters)", "s", "share"]


if __name__ == "__main__":
    print(json.dumps(probe(sys.argv[1])))
