"""Section ``matrices``: wall time of ``foucault-bench run`` on the quick and default matrices, cold and warm.

Each matrix runs as a user would run it (``foucault-bench run --matrix NAME --db TMP``, one worker per core),
every time into a fresh results database, with every compilation cache (numba, heyoka, reference solutions)
in one fresh directory: the first run starts cold, the next ones find the caches filled (warm; the quick
matrix is run warm ``QUICK_WARM_RUNS`` times and the median taken, as its few seconds are noisy). Targets: a
warm quick run takes ≤ 30 % of the cold one (compile once), and the default matrix takes ≤ 5 minutes.
``--quick`` runs the quick matrix only.

Where the time goes is read back from the stored rows: per run, warm-up + timed repeats ≈
``compile_time_s + repeats × cpu_time_s`` (bench.run.timing's protocol: the warm-up is the run over the first
output interval, its CPU time ``compile_time_s``; CPU time, so that the figure does not grow with the machine's
load; the fixed-step loops' untimed monitored call is left out), summed per integrator; the
remainder of the wall time (× the workers) is start-up, references and scheduling.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from pathlib import Path

import pandas as pd

from foucault_bench.bench.perf.measure import Row, cache_environment, run_timed
from foucault_bench.bench.run.store import ResultsStore

SECTION = "matrices"
TARGET_WARM_FRACTION = 0.30
TARGET_DEFAULT_S = 300.0
QUICK_WARM_RUNS = 3


def run_matrix(name: str, root: Path, db: Path) -> float:
    """Run one matrix with the caches under ``root``; its wall time (s). Raises if the command fails."""
    command = [sys.executable, "-m", "foucault_bench.bench.cli", "run", "--matrix", name, "--db", str(db), "--no-progress"]
    wall_s, done = run_timed(command, cache_environment(root))
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr.strip()[-2000:]}")
    return wall_s


def time_spent(db: Path) -> pd.DataFrame:
    """Per stored run: scene, integrator, setting and its estimated busy time (s) in a worker."""
    with ResultsStore(db, create=False) as store:
        frame = store.frame()
    repeats = frame["repeats"].fillna(0)
    frame["busy_s"] = frame["compile_time_s"].fillna(0) + frame["cpu_time_s"].fillna(0) * repeats
    return frame


def dominant(frame: pd.DataFrame, label: str, wall_s: float, jobs: int) -> list[list[str]]:
    """Detail rows: busy time per integrator, largest first, with its share of the workers' capacity."""
    capacity = wall_s * jobs
    per_integrator = frame.groupby("integrator")["busy_s"].agg(["sum", "count", "max"]).sort_values("sum", ascending=False)
    table = [[label, integrator, int(row["count"]), f"{row['sum']:.1f}", f"{100 * row['sum'] / capacity:.0f} %",
              f"{row['max']:.1f}"] for integrator, row in per_integrator.iterrows()]
    table.append([label, "(start-up, references, idle)", "", f"{capacity - frame['busy_s'].sum():.1f}",
                  f"{100 * (1 - frame['busy_s'].sum() / capacity):.0f} %", ""])
    return table


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Cold and warm matrix runs; the rows, a table of where the time went and its headers."""
    from foucault_bench.bench.provenance import available_cores

    jobs = available_cores()
    headers = ["run", "integrator", "runs", "busy s", "share of workers' time", "longest run s"]
    rows, table, walls = [], [], {}
    for name in ("quick",) if quick else ("quick", "default"):
        with tempfile.TemporaryDirectory(prefix=f"foucault-perf-{name}-") as directory:
            root = Path(directory)
            for state in ("cold", "warm"):
                repeats = QUICK_WARM_RUNS if (name, state) == ("quick", "warm") else 1
                runs = [run_matrix(name, root, root / f"{state}{i}.sqlite") for i in range(repeats)]
                walls[name, state] = statistics.median(runs)
                table.extend(dominant(time_spent(root / f"{state}0.sqlite"), f"{name} {state}", runs[0], jobs))
                target = TARGET_DEFAULT_S if name == "default" else None
                note = f"median of {repeats}: {', '.join(f'{wall:.1f}' for wall in runs)} s" if repeats > 1 else ""
                rows.append(Row(SECTION, f"{name} matrix, {state} caches, {jobs} workers: wall time",
                                walls[name, state], "s", target, note))
    rows.append(Row(SECTION, "compile once: warm quick run / cold one", walls["quick", "warm"] / walls["quick", "cold"],
                    "×", TARGET_WARM_FRACTION, f"{walls['quick', 'warm']:.1f} s vs {walls['quick', 'cold']:.1f} s"))
    return rows, table, headers
