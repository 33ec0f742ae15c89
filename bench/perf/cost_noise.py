"""The noise of the cost-change rule: false alarms on the same code run twice, detection of a 10 % slowdown.

    python -m foucault_bench.bench.perf.cost_noise [--out DIR] [--rounds N] [--jobs J]
    python -m foucault_bench.bench.perf.cost_noise --compare DIR   # compare the rounds stored in DIR again
    python -m foucault_bench.bench.perf.cost_noise --paired [--out DIR] [--rounds N] [--cycles C] [--process-sets P]

Runs a small noise matrix (``NOISE_MATRIX``: fixed-step and adaptive integrators on the 3 m pendulum for two
hours, runs of 10 ms to 0.5 s) ``rounds`` times with the same code and, between them, once more with rk4 slowed
by 10 % of its CPU time (the plug-in ``bench.perf.slowed_rk4``), each into its own database under ``DIR``
through the ``foucault-bench run`` command, as a user runs it. It then compares, with
``bench.history.changes.cost_change`` (the rule ``history`` and ``check --baseline --cost`` apply):

* every pair of same-code rounds, on every run of ≥ ``MIN_COST_S`` that is ok on both sides: the share
  flagged as a cost change is the false-alarm rate (target ≤ 5 %);
* each same-code round against the slowed round, on rk4's runs: the share flagged as a slowdown (ratio > 1)
  is the detection rate (target ≥ 95 %); every slowed rk4 row must carry the plug-in's marker in its message,
  or the measurement is void (the slowed code did not reach the workers).

The other integrators' code is the same in the slowed round: their runs there count as same-code pairs too.
It prints a Markdown table with the load average before and after each round (``os.getloadavg``), the ratios
the rule compares and those of the calibrated medians beside them (what the calibration would remove).

``--paired`` measures the paired rule instead (``bench.history.paired_cost``,
``bench.history.changes.paired_cost_change``): in each of ``rounds`` sessions three workers time the noise
matrix's solves in turn, two with the same code (``same1``, ``same2``) and one with the slowed rk4 (``slowed``;
the plug-in is imported by that worker itself, which ends with an error if it cannot), ``cycles`` cycles per
run in each of ``process_sets`` sets of fresh workers. Same-code pairs: same1 against same2 on every run, and
each of them against slowed on every run but rk4's; detection: each against slowed on rk4's runs. The runs
counted are those whose same1 median is ≥ ``MIN_COST_S``. The times are kept in ``DIR/paired.json``
(``--compare DIR`` reports them again).
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pandas as pd

from foucault_bench.bench.atomic import write_text_file
from foucault_bench.bench.history.changes import MIN_COST_S, MIN_PAIRS, cost_change, paired_cost_change
from foucault_bench.bench.history.paired_cost import Side, paired_times
from foucault_bench.bench.run.compare import run_identity
from foucault_bench.bench.run.store import ResultsStore

SLOWED_PLUGIN = "foucault_bench.bench.perf.slowed_rk4"
MARKER = "slowed by 10 % (bench.perf.slowed_rk4)"
"""What the plug-in appends to its runs' messages (defined here: importing the plug-in replaces rk4)."""
ROUNDS_FILE = "rounds.json"
PAIRED_FILE = "paired.json"
PAIRED_SIDES = (Side("same1"), Side("same2"), Side("slowed", plugins=(SLOWED_PLUGIN,)))
NOISE_MATRIX = textwrap.dedent("""\
    name = "cost-noise"
    description = "runs of 10 ms to 0.5 s for the cost-change rule's noise (bench.perf.cost_noise)"
    integrators = ["rk4", "verlet", "yoshida4", "gauss_legendre4", "dopri5", "dop853", "tsit5", "cvode_adams"]
    kh = [0.1, 0.05, 0.025, 0.0125]
    tol = [1e-6, 1e-8, 1e-10]

    [scene.lab_3m_2h]
    base = "lab_3m"
    duration_s = 7200.0

    [override.rk4]
    kh = [0.2, 0.16, 0.125, 0.1, 0.08, 0.0625, 0.05, 0.04, 0.03125, 0.025, 0.02, 0.016]
    """)


def run_round(directory: Path, name: str, *, slowed: bool, jobs: int) -> dict:
    """One round of the noise matrix into ``directory/name.sqlite``; its wall time and the load around it."""
    matrix_path = directory / f"{name}.toml"
    plugins = f"plugins = [{json.dumps(SLOWED_PLUGIN)}]\n" if slowed else ""
    matrix_path.write_text(plugins + NOISE_MATRIX)
    database = directory / f"{name}.sqlite"
    command = [sys.executable, "-m", "foucault_bench.bench.cli", "run", "--matrix", str(matrix_path),
               "--db", str(database), "--jobs", str(jobs), "--no-progress"]
    load_before = os.getloadavg()[0]
    start_s = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return dict(name=name, database=database, wall_s=time.perf_counter() - start_s,
                load=(load_before, os.getloadavg()[0]), slowed=slowed)


def rows_of(database: Path) -> pd.DataFrame:
    """The round's ok rows of ≥ ``MIN_COST_S``, indexed by what the run is."""
    with ResultsStore(database, create=False) as store:
        frame = store.frame()
    frame = frame[(frame["status"] == "ok") & (frame["cpu_time_s"] >= MIN_COST_S)].copy()
    frame.index = run_identity(frame)
    return frame


def compare(before: pd.DataFrame, after: pd.DataFrame, *, rk4: bool | None = None) -> dict:
    """Every common run (only rk4's, or all but rk4's, when ``rk4`` says so) compared by ``cost_change``:
    counts flagged (any direction, and slower), the rule's ratios and those of calibrated medians."""
    common = [run for run in before.index.intersection(after.index)
              if rk4 is None or (before.loc[run, "integrator"] == "rk4") == rk4]
    flagged = slower = 0
    ratios, calibrated = [], []
    for run in common:
        comparison = cost_change(before.loc[run], after.loc[run])
        assert comparison is not None, run  # every new row stores its repeats
        flagged += comparison.changed
        slower += comparison.changed and comparison.ratio > 1
        ratios.append(comparison.ratio)
        calibrated.append(float(after.loc[run, "cpu_time_s"] / after.loc[run, "calibration_cpu_s"])
                          / float(before.loc[run, "cpu_time_s"] / before.loc[run, "calibration_cpu_s"]))
    return dict(runs=len(common), flagged=flagged, slower=slower, ratios=ratios, calibrated=calibrated)


def _range(values: list[float]) -> str:
    return f"{min(values):.3f}-{max(values):.3f} (median {statistics.median(values):.3f})" if values else "–"


def report(rounds: list[dict]) -> str:
    """The Markdown tables of the measurement (module docstring)."""
    frames = {round_["name"]: rows_of(round_["database"]) for round_ in rounds}
    slowed = [round_["name"] for round_ in rounds if round_["slowed"]]
    same = [round_["name"] for round_ in rounds if not round_["slowed"]]
    for name in slowed:
        rk4 = frames[name][frames[name]["integrator"] == "rk4"]
        if not len(rk4) or not rk4["message"].fillna("").str.contains(MARKER, regex=False).all():
            raise SystemExit(f"{name}: the slowed rk4 did not reach the workers (no marker in its rows)")
    lines = ["| round | wall (s) | load average (1 min) before → after |", "|---|---|---|"]
    lines += [f"| {r['name']}{' (rk4 slowed 10 %)' if r['slowed'] else ''} | {r['wall_s']:.0f} | "
              f"{r['load'][0]:.1f} → {r['load'][1]:.1f} |" for r in rounds]
    lines += ["", "| comparison | runs | flagged | ratios after / before | calibrated ratios |", "|---|---|---|---|---|"]
    total = flagged = 0
    same_code: list[tuple[str, str, bool | None, str]] = [(a, b, None, "same code") for a, b in itertools.combinations(same, 2)]
    same_code += [(a, b, False, "same code: all but rk4") for a, b in itertools.product(same, slowed)]
    for a, b, rk4, what in same_code:
        result = compare(frames[a], frames[b], rk4=rk4)
        total, flagged = total + result["runs"], flagged + result["flagged"]
        lines.append(f"| {a} vs {b} ({what}) | {result['runs']} | {result['flagged']} | "
                     f"{_range(result['ratios'])} | {_range(result['calibrated'])} |")
    found = runs = 0
    for a, b in itertools.product(same, slowed):
        result = compare(frames[a], frames[b], rk4=True)
        runs, found = runs + result["runs"], found + result["slower"]
        lines.append(f"| {a} vs {b} (rk4 slowed) | {result['runs']} | {result['slower']} slower | "
                     f"{_range(result['ratios'])} | {_range(result['calibrated'])} |")
    lines += ["", f"False alarms: {flagged} of {total} ({100 * flagged / max(total, 1):.1f} %, target ≤ 5 %). "
              f"Slowdown found: {found} of {runs} ({100 * found / max(runs, 1):.1f} %, target ≥ 95 %)."]
    return "\n".join(lines)


def paired_round(directory: Path, *, cycles: int, process_sets: int) -> dict:
    """One session of paired timing of the noise matrix (module docstring, ``--paired``): per run index, each
    side's CPU times; the load around it and the session's CPU time (its workers' user + system)."""
    matrix_path = directory / "paired.toml"
    matrix_path.write_text(NOISE_MATRIX)
    load_before, cpu_before = os.getloadavg()[0], _children_cpu_s()
    _, times = paired_times(matrix_path, PAIRED_SIDES, cycles=cycles, process_sets=process_sets)
    return dict(times={str(index): samples for index, samples in times.items()},
                load=(load_before, os.getloadavg()[0]), cpu_s=_children_cpu_s() - cpu_before)


def _children_cpu_s() -> float:
    usage = os.times()
    return usage.children_user + usage.children_system


def paired_counts(rounds: list[dict], integrators: dict[str, str]) -> dict:
    """The paired comparisons of every round (module docstring, ``--paired``): same-code pairs compared and
    flagged, rk4 pairs compared and found slower, and the ratios of each kind. ``integrators``: run index →
    integrator."""
    counts: dict[str, int] = dict(same=0, flagged=0, rk4=0, found=0)
    ratios: dict[str, list[float]] = dict(same_ratios=[], rk4_ratios=[])
    flagged_runs: list[str] = []
    for round_ in rounds:
        for index, samples in round_["times"].items():
            if statistics.median(samples["same1"]) < MIN_COST_S:
                continue
            rk4 = integrators[index] == "rk4"
            pairs = [("same1", "same2", False)] + [(side, "slowed", rk4) for side in ("same1", "same2")]
            for before, after, slowed in pairs:
                comparison = paired_cost_change(samples[before], samples[after])
                if slowed:
                    counts["rk4"] += 1
                    counts["found"] += comparison.changed and comparison.ratio > 1
                    ratios["rk4_ratios"].append(comparison.ratio)
                else:
                    counts["same"] += 1
                    counts["flagged"] += comparison.changed
                    ratios["same_ratios"].append(comparison.ratio)
                    if comparison.changed:
                        flagged_runs.append(f"{integrators[index]} {before}/{after} ×{comparison.ratio:.3f}")
    return dict(counts, **ratios, flagged_runs=flagged_runs)


def paired_report(rounds: list[dict]) -> str:
    """The Markdown summary of a paired measurement (module docstring, ``--paired``)."""
    with tempfile.TemporaryDirectory() as temporary:
        matrix_path = Path(temporary) / "paired.toml"
        matrix_path.write_text(NOISE_MATRIX)
        from foucault_bench.bench.run.matrix import load_matrix

        integrators = {str(index): spec.integrator for index, spec in enumerate(load_matrix(matrix_path).runs)}
    lines = ["| session | CPU (s) | load average (1 min) before → after |", "|---|---|---|"]
    lines += [f"| {number} | {r['cpu_s']:.0f} | {r['load'][0]:.1f} → {r['load'][1]:.1f} |"
              for number, r in enumerate(rounds, 1)]
    counts = paired_counts(rounds, integrators)
    flagged_runs = ", ".join(counts["flagged_runs"]) or "none"
    lines += ["", f"Same-code pairs: ratios {_range(counts['same_ratios'])}; slowed rk4: ratios "
              f"{_range(counts['rk4_ratios'])}. Flagged same-code pairs: {flagged_runs}.",
              "", f"False alarms: {counts['flagged']} of {counts['same']} "
              f"({100 * counts['flagged'] / max(counts['same'], 1):.1f} %, target ≤ 5 %). Slowdown found: "
              f"{counts['found']} of {counts['rk4']} ({100 * counts['found'] / max(counts['rk4'], 1):.1f} %, "
              "target ≥ 95 %)."]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m foucault_bench.bench.perf.cost_noise", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, help="folder for the databases (default: a temporary one)")
    parser.add_argument("--rounds", type=int, default=2,
                        help="same-code rounds, or with --paired sessions (at least 2; default 2)")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes per round (default 2)")
    parser.add_argument("--compare", type=Path, metavar="DIR", help="no new rounds: compare those of an earlier --out DIR")
    parser.add_argument("--paired", action="store_true",
                        help="measure the paired rule: the sides' solves alternated in one session per round")
    parser.add_argument("--cycles", type=int, default=5, help="with --paired: cycles per run and process set "
                                                               "(default 5)")
    parser.add_argument("--process-sets", type=int, default=2,
                        help="with --paired: sets of fresh workers per session (default 2)")
    arguments = parser.parse_args(argv)
    if arguments.rounds < 2 or arguments.jobs < 1:
        parser.error("need --rounds >= 2 and --jobs >= 1")
    if arguments.paired and arguments.cycles * arguments.process_sets < MIN_PAIRS:
        parser.error(f"--paired needs --cycles × --process-sets >= {MIN_PAIRS} (the signed-rank test's pairs)")
    if arguments.paired or (arguments.compare is not None and (arguments.compare / PAIRED_FILE).is_file()):
        return paired_main(arguments)
    if arguments.compare is not None:
        rounds = json.loads((arguments.compare / ROUNDS_FILE).read_text())
        print(report([dict(round_, database=arguments.compare / f"{round_['name']}.sqlite") for round_ in rounds]))
        return 0
    with tempfile.TemporaryDirectory() as temporary:
        directory = arguments.out or Path(temporary)
        directory.mkdir(parents=True, exist_ok=True)
        names = [f"same{index + 1}" for index in range(arguments.rounds)]
        order = [names[0], "slowed", *names[1:]]  # the slowed round between same-code ones: drift shows in both
        rounds = []
        for name in order:
            rounds.append(run_round(directory, name, slowed=name == "slowed", jobs=arguments.jobs))
            write_text_file(directory / ROUNDS_FILE, json.dumps([{key: value for key, value in round_.items()
                                                                  if key != "database"} for round_ in rounds]), "--out")
        print(report(rounds))
    return 0


def paired_main(arguments: argparse.Namespace) -> int:
    """``--paired``, or ``--compare`` of a folder a paired measurement wrote."""
    if arguments.compare is not None:
        print(paired_report(json.loads((arguments.compare / PAIRED_FILE).read_text())))
        return 0
    with tempfile.TemporaryDirectory() as temporary:
        directory = arguments.out or Path(temporary)
        directory.mkdir(parents=True, exist_ok=True)
        rounds: list[dict] = []
        for _ in range(arguments.rounds):
            rounds.append(paired_round(directory, cycles=arguments.cycles, process_sets=arguments.process_sets))
            write_text_file(directory / PAIRED_FILE, json.dumps(rounds), "--out")
        print(paired_report(rounds))
    return 0


if __name__ == "__main__":
    sys.exit(main())
