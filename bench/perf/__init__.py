"""``foucault-bench perf``: the suite's own speed, against the hardware and the bare libraries, with targets.

    foucault-bench perf                       # every section (about 10 minutes on 2 cores, see bench/PERF.md)
    foucault-bench perf --quick               # a fast subset of every section, to try the harness
    foucault-bench perf --only loops --only memory
    foucault-bench perf --markdown perf.md    # also write the tables as Markdown (the figures of PERF.md)

Sections (one module each; each returns target rows and a detail table):

* ``loops`` (``fixed_step``): fixed-step loops against plain C loops compiled now with ``cc -O3``;
* ``adapters``: CVODE, heyoka and solve_ivp adapters against the bare libraries;
* ``compile`` (``compile_cache``): cold and warm compile time per integrator;
* ``memory``: peak RSS of 10⁷- and 10⁸-step runs with streaming verdicts;
* ``sweeps``: a latitude sweep with heyoka's batch mode and ensembles against a scalar loop;
* ``batch``: an ensemble's members as one batch (``integrators.batch``) against one by one: a 1000-member RK4
  ensemble against its members' loop bodies, and references and heyoka runs in batch mode;
* ``matrices``: wall time of the quick and default matrices, cold and warm (compile once);
* ``limits``: each integrator family against its own limit (compiled CVODE per right-hand-side evaluation
  against scikit-sundae's, ``bench.perf.cvode``; the compiled Runge-Kutta pairs against scipy's at equal
  nfev, ``bench.perf.erk``; heyoka's adapter against bare heyoka) and ``cpu_time_s`` at ``--jobs 2`` against
  ``--jobs 1``.
* ``roundoff``: round-off growth of the symmetric schemes' invariant over 10⁸ steps, with and without
  compensated summation, and its cost (``bench.studies.long_time_roundoff``);
* ``startup``: ``--help`` of every command, and where a 5-run matrix's time goes (imports, validation,
  references, integration, store).

The summary prints one line per measured figure with its target and ``met``/``missed`` (``info`` where the
brief sets no target, ``skipped`` with the reason where it could not be measured, e.g. no C compiler). The
exit status is 0 whether targets are met or not: the table is the result.
"""

from __future__ import annotations

import importlib
import sys
import time
from pathlib import Path

from foucault_bench.bench.atomic import write_text_file
from foucault_bench.bench.perf.measure import ROW_HEADERS, Row, machine_description

SECTIONS: dict[str, str] = {
    "loops": "foucault_bench.bench.perf.fixed_step",
    "adapters": "foucault_bench.bench.perf.adapters",
    "compile": "foucault_bench.bench.perf.compile_cache",
    "memory": "foucault_bench.bench.perf.memory",
    "sweeps": "foucault_bench.bench.perf.sweeps",
    "batch": "foucault_bench.bench.perf.batch",
    "matrices": "foucault_bench.bench.perf.matrices",
    "limits": "foucault_bench.bench.perf.limits",
    "startup": "foucault_bench.bench.perf.startup",
    "roundoff": "foucault_bench.bench.perf.roundoff",
}


def _table(rows: list[list], headers: list[str], markdown: bool) -> str:
    from tabulate import tabulate

    return tabulate(rows, headers, tablefmt="github" if markdown else "simple", disable_numparse=True)


def run(sections: list[str], *, quick: bool, markdown_path: Path | None) -> int:
    """Measure ``sections`` (names of ``SECTIONS``; a fast subset of each with ``quick``), print every table and
    the targets, and also write them as Markdown to ``markdown_path``; exit status 0 (the table is the result)."""
    from foucault_bench.bench.run.timing import limit_threads

    limit_threads()  # one thread per native pool, as in the runner's workers (set before numpy is imported)
    machine = machine_description()
    print("\n".join(f"{key}: {value}" for key, value in machine.items()), flush=True)
    summary: list[Row] = []
    markdown = ["## Machine", "", *[f"- {key}: {value}" for key, value in machine.items()], ""]
    for name in sections:
        started = time.perf_counter()
        print(f"\n== {name} ==", flush=True)
        rows, table, headers = importlib.import_module(SECTIONS[name]).run(quick)
        elapsed = time.perf_counter() - started
        if table:
            print(_table(table, headers, markdown=False), flush=True)
        print(f"({name}: {elapsed:.0f} s)", flush=True)
        summary.extend(rows)
        markdown += [f"## {name} ({elapsed:.0f} s)", "", _table(table, headers, markdown=True), ""]
    print("\n== targets ==")
    print(_table([row.cells() for row in summary], ROW_HEADERS, markdown=False))
    counts = {verdict: sum(row.verdict == verdict for row in summary) for verdict in ("met", "missed", "info", "skipped")}
    print(", ".join(f"{count} {verdict}" for verdict, count in counts.items()))
    if markdown_path:
        markdown += ["## Targets", "", _table([row.cells() for row in summary], ROW_HEADERS, markdown=True), ""]
        write_text_file(markdown_path, "\n".join(markdown), "--markdown")
        print(f"tables written to {markdown_path}", file=sys.stderr)
    return 0
