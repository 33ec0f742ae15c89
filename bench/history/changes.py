"""What changed between two revisions: accuracy columns bit for bit, costs only beyond the noise of both runs.

Rows are lined up by what a run is (``bench.run.compare.run_identity``: the scene by name and physics key, the
integrator, the exact setting), whatever the code version that made them.

* **Accuracy** (``ACCURACY_COLUMNS``: the status, the verdicts, the counts): a change is any difference of the bits
  (``bench.run.store``'s bitwise identity; NaN equals NaN), because these columns are deterministic for one
  matrix on one machine (a column a matrix may leave out, ``bench.schema.OPTIONAL_VERDICT_COLUMNS``, is compared
  only where both rows hold it). Between two machines (another CPU model on the two sides) the compiled code of
  numba and heyoka (LLVM, tuned to the host CPU) may round differently, so real-valued columns there count as
  changed only beyond ``CROSS_MACHINE_RELATIVE`` of the larger value or ``CROSS_MACHINE_ABSOLUTE`` (a round-off
  level of the relative errors); counts and statuses stay exact. Both tolerances are choices stated here, not
  measurements.
* **Cost** (CPU time): each run's timed repeats (``cpu_time_repeats_s``). Between two machines (another CPU
  model on the two sides) they are divided by the calibration timed beside each run (``calibration_cpu_s``, a
  fixed compiled loop, ``bench.run.calibration``), so that machine speed cancels; on one machine they are
  compared as measured, because there the calibration only adds its own noise (measured in bench/PERF.md
  "Cost changes across revisions": it does not follow the run-to-run shifts of the runs' costs). A change
  needs an effect beyond the noise of both runs: the ratio of the medians beyond ``1 ± COST_MIN_EFFECT`` and
  beyond the sum of the two medians' 95 % half-widths (``cpu_time_ci95_rel``, or half the repeats' range
  relative to the median where the row states no interval): the two intervals do not overlap; and, where both
  sides have ``MIN_REPEATS_FOR_TEST`` repeats, a two-sided Mann–Whitney U test (as asv's ``compare`` uses;
  scipy.stats.mannwhitneyu) at ``COST_SIGNIFICANCE``. Rows without stored repeats (an older database) have no
  cost comparison. Its false-alarm and detection rates on a busy machine are measured by
  ``bench.perf.cost_noise`` (bench/PERF.md): on a busy shared machine two runs measured at different times
  differ by more than this rule allows for (the adaptive drivers by 5-30 %), so it over-reports there.
* **Paired cost** (``paired_cost_change``): the two code versions' solves alternated in one session
  (``bench.history.paired_cost``), one timed solve of each per cycle. The ratio is the exponential of the
  median of the per-cycle log-ratios after/before; a change needs that ratio beyond ``1 ± COST_MIN_EFFECT``
  and a two-sided Wilcoxon signed-rank test of the log-ratios against 0 (scipy.stats.wilcoxon) at
  ``COST_SIGNIFICANCE``, with at least ``MIN_PAIRS`` pairs. What the machine does between cycles cancels in
  each ratio; its false-alarm and detection rates are measured by ``bench.perf.cost_noise --paired``.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.history.revisions import Revision
from foucault_bench.bench.run.compare import DETERMINISTIC_COLUMNS, run_identity
from foucault_bench.bench.schema import OPTIONAL_VERDICT_COLUMNS, setting_label

ACCURACY_COLUMNS: tuple[str, ...] = tuple(column for column in DETERMINISTIC_COLUMNS if column not in ("kh", "tol"))
"""The columns compared bit for bit (the setting itself is part of what a run is)."""
INTEGER_COLUMNS = ("status", "n_out", "nfev", "njev", "steps", "rejected_steps")
CROSS_MACHINE_RELATIVE = 1e-6
CROSS_MACHINE_ABSOLUTE = 1e-13
COST_MIN_EFFECT = 0.05
"""Smallest cost change reported: 5 %, above the ±3 % precision the timing protocol aims at for each median."""
COST_SIGNIFICANCE = 0.01
MIN_REPEATS_FOR_TEST = 5
"""Fewest repeats per side for the rank test: with 5 and 5 the smallest two-sided p is 2/252 ≈ 0.008 < 0.01."""
MIN_PAIRS = 8
"""Fewest pairs for the signed-rank test: with 8 pairs the smallest two-sided p is 2/2⁸ ≈ 0.008 < 0.01."""
MIN_COST_S = 0.01
"""Runs faster than 10 ms are compared too, but the noise figures of bench/PERF.md are stated for runs ≥ 10 ms."""


@dataclass(frozen=True)
class Change:
    """One change of one run between two revisions (``kind``: ``accuracy`` or ``cost``)."""

    run: str
    scene: str
    integrator: str
    setting: str
    kind: str
    column: str
    before_revision: str
    after_revision: str
    before: Any
    after: Any
    detail: str = ""


@dataclass(frozen=True)
class CostComparison:
    """The CPU-time ratio after/before (of calibrated medians), its evidence and whether it is a change."""

    ratio: float
    changed: bool
    method: str
    p_value: float | None = None


def lined_up(frame: pd.DataFrame, revisions: Sequence[Revision]) -> pd.DataFrame:
    """The rows of ``frame`` (every matrix run's) with their revision (``revision``: label, ``revision_index``:
    position), ``run``, display ``scene_label`` and ``setting``; a run stored twice in one revision keeps its
    latest row. Rows of matrix runs of no revision are dropped."""
    index = {matrix_id: position for position, revision in enumerate(revisions) for matrix_id in revision.matrix_ids}
    rows = frame[frame["matrix_id"].isin(index)].copy()
    rows["revision_index"] = rows["matrix_id"].map(index).astype(int)
    rows["revision"] = [revisions[position].label for position in rows["revision_index"]]
    rows["run"] = run_identity(rows)
    from foucault_bench.bench.problems.scene_key import scene_labels

    rows["scene_label"] = scene_labels(rows)
    rows["setting"] = [setting_label(kh, tol) for kh, tol in zip(rows["kh"], rows["tol"], strict=True)]
    return rows.drop_duplicates(["revision_index", "run"], keep="last").sort_values(["run", "revision_index"],
                                                                                  kind="stable")


def _missing(value: Any) -> bool:
    return value is None or (isinstance(value, (float, np.floating)) and math.isnan(value)) or value is pd.NA


def identical(before: Any, after: Any) -> bool:
    """The same stored value: numbers by their 64-bit patterns (NaN equals NaN, −0.0 ≠ 0.0), missing equals
    missing, others by value."""
    if _missing(before) or _missing(after):
        return _missing(before) and _missing(after)
    numbers = (int, float, np.integer, np.floating)
    if isinstance(before, numbers) and isinstance(after, numbers):
        return np.float64(before).tobytes() == np.float64(after).tobytes()
    return before == after


def _same(column: str, before: Any, after: Any, *, cross_machine: bool) -> bool:
    if identical(before, after):
        return True
    if column in OPTIONAL_VERDICT_COLUMNS and (_missing(before) or _missing(after)):
        return True  # left out by one side's matrix (step_energy = false): nothing to compare
    if not cross_machine or column in INTEGER_COLUMNS:
        return False
    try:
        a, b = float(before), float(after)
    except (TypeError, ValueError):
        return False
    return math.isclose(a, b, rel_tol=CROSS_MACHINE_RELATIVE, abs_tol=CROSS_MACHINE_ABSOLUTE)


def accuracy_changes(before: Mapping[str, Any], after: Mapping[str, Any], *, cross_machine: bool = False) -> list[str]:
    """The accuracy columns whose values differ between two rows of one run."""
    return [column for column in ACCURACY_COLUMNS
            if column in before and not _same(column, before[column], after[column], cross_machine=cross_machine)]


def cost_samples(row: Mapping[str, Any], *, calibrated: bool) -> np.ndarray | None:
    """The run's timed repeats (seconds), divided by its calibration when ``calibrated``; None without repeats."""
    text = row.get("cpu_time_repeats_s")
    if not isinstance(text, str) or not text:
        return None
    samples = np.asarray(json.loads(text), dtype=float)
    if not len(samples) or not np.all(np.isfinite(samples)):
        return None
    return samples / float(row["calibration_cpu_s"]) if calibrated else samples


def _has_calibration(row: Mapping[str, Any]) -> bool:
    value = row.get("calibration_cpu_s")
    return value is not None and pd.notna(value) and float(value) > 0


def half_width(samples: np.ndarray, ci95_rel: Any) -> float:
    """The relative 95 % half-width of a run's median: the stored one, else half the repeats' range over the
    median (0 for a single repeat)."""
    if ci95_rel is not None and pd.notna(ci95_rel) and math.isfinite(float(ci95_rel)):
        return float(ci95_rel)
    return float(samples.max() - samples.min()) / (2.0 * float(np.median(samples)))


def cost_change(before: Mapping[str, Any], after: Mapping[str, Any]) -> CostComparison | None:
    """Whether the CPU time of one run changed between two rows (module docstring); None when a side has no
    stored repeats."""
    from scipy.stats import mannwhitneyu

    calibrated = _cross_machine(before, after) and _has_calibration(before) and _has_calibration(after)
    a, b = cost_samples(before, calibrated=calibrated), cost_samples(after, calibrated=calibrated)
    if a is None or b is None:
        return None
    ratio = float(np.median(b) / np.median(a))
    noise = half_width(a, before.get("cpu_time_ci95_rel")) + half_width(b, after.get("cpu_time_ci95_rel"))
    large = abs(math.log(ratio)) > max(math.log1p(COST_MIN_EFFECT), noise)
    suffix = "calibrated" if calibrated else "one machine"
    if len(a) >= MIN_REPEATS_FOR_TEST and len(b) >= MIN_REPEATS_FOR_TEST:
        p_value = float(mannwhitneyu(a, b, alternative="two-sided").pvalue)
        return CostComparison(ratio, large and p_value < COST_SIGNIFICANCE,
                              f"beyond both intervals, Mann-Whitney U, {suffix}", p_value)
    return CostComparison(ratio, large, f"beyond both intervals, {suffix}")


def paired_cost_change(before_s: Sequence[float], after_s: Sequence[float]) -> CostComparison:
    """Whether the CPU time changed between paired solves (module docstring, "Paired cost"): ``before_s[i]``
    and ``after_s[i]`` are the two versions' times (s) in cycle i. ``InputError`` for samples of different
    lengths, fewer than ``MIN_PAIRS`` pairs, or a time that is not a positive finite number."""
    from scipy.stats import wilcoxon

    if len(before_s) != len(after_s):
        raise InputError(f"paired costs: {len(before_s)} times before and {len(after_s)} after; pairs need as many")
    if len(before_s) < MIN_PAIRS:
        raise InputError(f"paired costs: {len(before_s)} pairs, the signed-rank test needs at least {MIN_PAIRS}")
    a, b = np.asarray(before_s, dtype=float), np.asarray(after_s, dtype=float)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b)) and np.all(a > 0) and np.all(b > 0)):
        raise InputError("paired costs: every time must be a positive finite number of seconds")
    log_ratios = np.log(b / a)
    ratio = float(np.exp(np.median(log_ratios)))
    p_value = 1.0 if not np.any(log_ratios) else float(wilcoxon(log_ratios, alternative="two-sided").pvalue)
    large = abs(math.log(ratio)) > math.log1p(COST_MIN_EFFECT)
    return CostComparison(ratio, large and p_value < COST_SIGNIFICANCE, "paired, Wilcoxon signed-rank", p_value)


def _cross_machine(before: Mapping[str, Any], after: Mapping[str, Any]) -> bool:
    models = before.get("cpu_model"), after.get("cpu_model")
    return all(isinstance(model, str) for model in models) and models[0] != models[1]


def row_changes(before: Mapping[str, Any], after: Mapping[str, Any], *, before_revision: str, after_revision: str,
                costs: bool = True) -> list[Change]:
    """Every change of one run between two of its rows: one per changed accuracy column, one for the cost."""
    where = dict(run=str(after["run"]), scene=str(after["scene_label"]), integrator=str(after["integrator"]),
                 setting=str(after["setting"]), before_revision=before_revision, after_revision=after_revision)
    found = [Change(kind="accuracy", column=column, before=before[column], after=after[column], **where)
             for column in accuracy_changes(before, after, cross_machine=_cross_machine(before, after))]
    comparison = cost_change(before, after) if costs else None
    if comparison is not None and comparison.changed:
        evidence = f"p = {comparison.p_value:.2g}, " if comparison.p_value is not None else ""
        found.append(Change(kind="cost", column="cpu_time_s", before=before["cpu_time_s"], after=after["cpu_time_s"],
                            detail=f"×{comparison.ratio:.3f} ({evidence}{comparison.method})", **where))
    return found


def history_changes(rows: pd.DataFrame) -> list[Change]:
    """The changes between consecutive revisions of each run in ``lined_up`` rows (a revision without the run
    is skipped: the next one is compared with the last that had it)."""
    records = rows.sort_values(["run", "revision_index"], kind="stable").to_dict("records")
    found: list[Change] = []
    for _, group in itertools.groupby(records, key=lambda record: record["run"]):
        ordered = list(group)
        for before, after in zip(ordered[:-1], ordered[1:], strict=True):
            found += row_changes(before, after, before_revision=str(before["revision"]),
                                 after_revision=str(after["revision"]))
    return found


def changes_frame(changes: Sequence[Change]) -> pd.DataFrame:
    """The changes as a table (one row each)."""
    columns = list(Change.__dataclass_fields__)
    return pd.DataFrame([[getattr(change, name) for name in columns] for change in changes], columns=columns)
