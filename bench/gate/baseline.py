"""``check --baseline``: the new rows compared with a baseline matrix run, as more lines of the gate.

Each run present in both (matched as ``bench.history.changes`` lines runs up) gives one ``baseline_accuracy``
check: it fails when an accuracy column differs (bit for bit, or beyond the cross-machine tolerance) unless an
``[[expected_change]]`` of the thresholds file selects that row and column. With ``cost`` each run with stored
timed repeats on both sides also gives a ``baseline_cost`` check: it fails on a slowdown beyond the noise of both
runs (``bench.history.changes.cost_change``). Those costs were measured at two different times: on a busy
shared machine they differ by more than either run's repeats show, and this check then fails about a third of
unchanged runs (bench/PERF.md "Cost changes across revisions"); ``check --cost-paired``
(``bench.gate.paired_cost_gate``) times both code versions in one session instead and meets the noise targets
there. A scene with other physics on the two sides is bad input: its runs are different scenes.
"""

from __future__ import annotations

import sys

import pandas as pd

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.gate.evaluate import Outcome
from foucault_bench.bench.gate.select import select_rows
from foucault_bench.bench.gate.thresholds import Bound, Selection, Thresholds
from foucault_bench.bench.history.changes import ACCURACY_COLUMNS, accuracy_changes, cost_change
from foucault_bench.bench.problems.scene_key import scene_labels
from foucault_bench.bench.run.compare import run_identity, scene_differences


def split_baseline(text: str) -> tuple[str, str | None]:
    """``DB`` or ``DB:MATRIX_ID`` → (database path, matrix id or None): an existing file is taken whole, so a
    path holding ``:`` works too."""
    from pathlib import Path

    if Path(text).is_file() or ":" not in text:
        return text, None
    database, matrix_id = text.rsplit(":", 1)
    return database, matrix_id or None


def _expected(thresholds: Thresholds, frame: pd.DataFrame) -> dict[int, set[str]]:
    """Row index of ``frame`` → the accuracy columns expected to change there (a change naming no columns: all)."""
    expected: dict[int, set[str]] = {}
    for change in thresholds.expected_changes:
        columns = set(change.columns or ACCURACY_COLUMNS)
        for index in select_rows(frame, change.selection).index:
            expected.setdefault(int(index), set()).update(columns)
    return expected


def baseline_outcomes(thresholds: Thresholds, frame: pd.DataFrame, baseline: pd.DataFrame, *, cost: bool,
                      what: str) -> list[Outcome]:
    """The baseline checks of ``frame`` against ``baseline`` (module docstring), numbered after the bounds."""
    differences = scene_differences(baseline, frame)
    if differences:
        raise InputError([f"--baseline: {text}" for text in differences.values()])
    first = len(thresholds.bounds) + 1
    everything = Selection(scenes=())
    accuracy_bound = Bound(first, everything, "baseline_accuracy", "unchanged",
                           basis=f"the accuracy columns are deterministic: any change from {what} is a new result")
    cost_bound = Bound(first + 1, everything, "baseline_cost", "within noise",
                       basis="a slowdown beyond the noise of both runs (bench.history.changes)")
    new = frame.assign(run=run_identity(frame, baseline), scene_label=scene_labels(frame, baseline))
    old = {record["run"]: record for record in baseline.assign(run=run_identity(baseline, frame)).to_dict("records")}
    expected = _expected(thresholds, frame)
    outcomes = []
    unmatched = uncosted = 0
    for index, row in zip(new.index, new.to_dict("records"), strict=True):
        if row["run"] not in old:
            unmatched += 1
            continue
        before = old[row["run"]]
        setting = row["run"].rsplit(" ", 1)[-1]
        changed = accuracy_changes(before, row)
        allowed = expected.get(int(index), set())
        unexpected = [column for column in changed if column not in allowed]
        detail = "; ".join(f"{column}: {before[column]!r} → {row[column]!r}"
                           + ("" if column in unexpected else " (expected)") for column in changed)
        outcomes.append(Outcome(accuracy_bound, str(row["scene_label"]), str(row["integrator"]), setting,
                                measured=f"{len(changed)} changed", margin=None, passed=not unexpected,
                                detail=detail))
        comparison = cost_change(before, row) if cost else None
        timed = pd.notna(before["cpu_time_s"]) and pd.notna(row["cpu_time_s"])
        uncosted += bool(cost and timed and comparison is None)
        if comparison is not None:
            slower = comparison.changed and comparison.ratio > 1
            outcomes.append(Outcome(cost_bound, str(row["scene_label"]), str(row["integrator"]), setting,
                                    measured=comparison.ratio, margin=None, passed=not slower,
                                    detail=f"×{comparison.ratio:.3f} CPU time ({comparison.method}"
                                           + (f", p = {comparison.p_value:.2g}" if comparison.p_value is not None else "")
                                           + ")"))
    missing = len(set(old) - set(new["run"]))
    if unmatched or missing:
        print(f"note: {unmatched} new run(s) have no row in {what} and {missing} of its runs are not among the new "
              "rows: they are not compared", file=sys.stderr)
    if uncosted:
        print(f"note: {uncosted} run(s) have no stored timed repeats on one side (a database older than the "
              "timing protocol's repeats column): their cost is not compared", file=sys.stderr)
    return outcomes
