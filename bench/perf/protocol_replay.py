"""Where a matrix run's CPU went, and what another timing policy would have spent, replayed on its stored repeats.

    python -m foucault_bench.bench.perf.protocol_replay DB [--matrix-id ID] [--max-total-s S] [--min-repeats N]
                                                        [--max-repeats N] [--target-ci95-rel X]

From the rows of one matrix run (``cpu_time_repeats_s``: the timed repeats' CPU times in the order measured):

* **where the CPU went**, core-seconds summed over the rows: the runs once (the monitored call of the
  integrators that stream step metrics, counted in the rows that hold what it streams,
  ``energy_max_rel_error_steps``: none in a matrix with ``step_energy = false``), the timed repeats, and the
  warm-up over the first output interval (``compile_time_s``: compilation or cache loads). Rows measured before
  2026-12-02 also spent a whole warm-up run each, one ``cpu_time_s``, which this breakdown does not count;
* **a replay of another policy** (``bench.run.timing.TimingPolicy``, the options above; the others keep the
  stored run's values): its stopping rule (``bench.run.timing.stop_repeating``) applied to the prefixes of each
  row's stored repeats. A policy that stops no later than the stored one is replayed exactly: the same
  repeats, cut where it would have stopped; a row where it would go on past the stored repeats is counted
  with all of them (a lower bound) and reported. For each row of ≥ ``MIN_COST_S``: whether the replayed
  median agrees with the stored one within the replayed precision (``cpu_time_ci95_rel`` of the prefix), or,
  where the prefix states none, within the stored row's.

Both are figures of one machine session: the replay isolates the protocol's own effect (how many repeats it
spends, how far a shorter series' median moves) from the machine's drift between two sessions, which the
calibration timed beside each run addresses (``bench.run.calibration``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import statistics
import sys
from typing import Any

import pandas as pd

from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.run.timing import TimingPolicy, median_ci95_rel, stop_repeating

MIN_COST_S = 0.01


def replayed_count(repeats_s: list[float], policy: TimingPolicy) -> int | None:
    """Repeats the policy would have made on this series: the first prefix where it stops; ``None`` when it
    would go on past the stored repeats."""
    for count in range(1, len(repeats_s) + 1):
        if stop_repeating(repeats_s[:count], policy):
            return count
    return None


def _once_s(row: Any) -> float:
    """The CPU time of the row's untimed monitored call: one run's cost where the row holds the per-step energy
    error that call streams (``energy_max_rel_error_steps``), none elsewhere."""
    return 0.0 if pd.isna(row.get("energy_max_rel_error_steps")) else float(row["cpu_time_s"])


def replay(frame: pd.DataFrame, policy: TimingPolicy) -> dict[str, Any]:
    """The CPU breakdown and the replay of ``policy`` over the timed rows of ``frame`` (module docstring)."""
    timed = frame[frame["cpu_time_repeats_s"].notna()]
    once_s = repeats_s = replayed_s = 0.0
    beyond = agree = disagree = no_precision = long_runs = 0
    for _, row in timed.iterrows():
        series = [float(value) for value in json.loads(row["cpu_time_repeats_s"])]
        once_s += _once_s(row)
        repeats_s += math.fsum(series)
        count = replayed_count(series, policy)
        beyond += count is None
        prefix = series[:count or len(series)]
        replayed_s += math.fsum(prefix)
        if float(row["cpu_time_s"]) < MIN_COST_S:
            continue
        long_runs += 1
        precision = median_ci95_rel(prefix)
        if precision is None and pd.notna(row["cpu_time_ci95_rel"]):
            precision = float(row["cpu_time_ci95_rel"])
        if precision is None:
            no_precision += 1
            continue
        moved = abs(statistics.median(prefix) / statistics.median(series) - 1.0)
        agree, disagree = agree + (moved <= precision), disagree + (moved > precision)
    return dict(rows=len(timed), once_s=once_s, repeats_s=repeats_s, compile_s=float(timed["compile_time_s"].sum()),
                replayed_repeats_s=replayed_s, beyond_stored=beyond, runs_of_10ms=long_runs, agree=agree,
                disagree=disagree, no_precision=no_precision)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m foucault_bench.bench.perf.protocol_replay",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("db", help="results database")
    parser.add_argument("--matrix-id", help="matrix run (default: the latest)")
    defaults = TimingPolicy()
    for field in dataclasses.fields(TimingPolicy):
        parser.add_argument(f"--{field.name.replace('_', '-')}", type=type(getattr(defaults, field.name)))
    arguments = parser.parse_args(argv)
    with ResultsStore(arguments.db, create=False) as store:
        frame = store.frame(arguments.matrix_id)
    changes = {field.name: getattr(arguments, field.name) for field in dataclasses.fields(TimingPolicy)
               if getattr(arguments, field.name) is not None}
    policy = dataclasses.replace(defaults, **changes)
    if policy.problems():
        parser.error("; ".join(policy.problems()))
    result = replay(frame, policy)
    print(f"policy: {policy}")
    for key, value in result.items():
        print(f"{key}: {value:.1f}" if isinstance(value, float) else f"{key}: {value}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
