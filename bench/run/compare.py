"""Two matrix runs compared run by run: the deterministic columns bit for bit, the costs as ratios.

``foucault-bench results --compare A B`` prints what ``compare_runs`` finds (bench/README.md "The results
store"); ``bench.perf`` uses it to check that two runs of one matrix agree.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from foucault_bench.bench.problems.scene_key import UNKNOWN_KEY_LABEL, scene_labels
from foucault_bench.bench.schema import OPTIONAL_VERDICT_COLUMNS, VERDICT_COLUMNS

if TYPE_CHECKING:  # pandas is imported by the functions that use it, not at start-up
    import pandas as pd

DETERMINISTIC_COLUMNS: tuple[str, ...] = (
    "status", "n_out", "step_s", "kh", "tol", "precession_rate_rad_s", *VERDICT_COLUMNS,
    "nfev", "njev", "steps", "rejected_steps",
)
"""Columns that must be identical bit for bit when the same matrix runs twice on the same machine."""

COST_COLUMNS: tuple[str, ...] = ("cpu_time_s", "wall_time_s", "compile_time_s", "peak_rss_mb")


def _bits_equal(left: pd.Series, right: pd.Series) -> pd.Series:
    """Element-wise identity: floats compared by their 64-bit patterns (NaN equals NaN, −0.0 ≠ 0.0), others
    by value with missing equal to missing."""
    import pandas as pd
    import numpy as np

    if pd.api.types.is_numeric_dtype(left) and pd.api.types.is_numeric_dtype(right):
        left_bits = left.to_numpy(dtype=np.float64).view(np.int64)
        right_bits = right.to_numpy(dtype=np.float64).view(np.int64)
        both_nan = np.isnan(left.to_numpy(dtype=np.float64)) & np.isnan(right.to_numpy(dtype=np.float64))
        return pd.Series((left_bits == right_bits) | both_nan, index=left.index)
    return (left == right) | (left.isna() & right.isna())


def run_identity(frame: pd.DataFrame, among: pd.DataFrame | None = None) -> pd.Series:
    """``scene integrator kh=…|tol=…`` per row, with the exact setting (float repr): what a run is, whatever
    the code version that produced it (run keys include the code version, so they differ across versions). The
    scene is its label among ``frame`` and ``among`` (``bench.problems.scene_key.scene_labels``): a name with
    two physics gives two scenes."""
    import pandas as pd

    settings = [f"tol={float(tol)!r}" if pd.notna(tol) else f"kh={float(kh)!r}"
                for kh, tol in zip(frame["kh"], frame["tol"], strict=True)]
    return scene_labels(frame, among) + " " + frame["integrator"] + " " + pd.Series(settings, index=frame.index)


def scene_differences(frame_a: pd.DataFrame, frame_b: pd.DataFrame) -> dict[str, str]:
    """Scene name → why its runs in A and B are different scenes, for every name both hold with other physics
    (``scene_key``; rows of unknown physics are a physics of their own)."""

    def keys(frame: pd.DataFrame) -> dict[str, set[str]]:
        found: dict[str, set[str]] = {}
        column = frame["scene_key"] if "scene_key" in frame.columns else [None] * len(frame)
        for name, key in zip(frame["scene"], column, strict=True):
            found.setdefault(str(name), set()).add(key if isinstance(key, str) else UNKNOWN_KEY_LABEL)
        return found

    in_a, in_b = keys(frame_a), keys(frame_b)
    return {name: f"scene {name} has other physics in A ({', '.join(sorted(in_a[name]))}) than in B "
                  f"({', '.join(sorted(in_b[name]))}): its runs are different scenes and are not compared"
            for name in sorted(set(in_a) & set(in_b)) if in_a[name] != in_b[name]}


def compare_runs(frame_a: pd.DataFrame, frame_b: pd.DataFrame
                 ) -> tuple[pd.DataFrame, pd.DataFrame, list[tuple[str, str]]]:
    """Compare two matrix runs row by row, matched on ``run_identity`` (scene name and physics, integrator,
    exact setting).

    Returns (mismatches, costs, unmatched): one mismatch line per differing deterministic column of a row
    (``DETERMINISTIC_COLUMNS``; must be empty for the same matrix and code on the same machine; a column a
    matrix may leave out, ``OPTIONAL_VERDICT_COLUMNS``, only where both rows hold it), the costs of A
    and B and their ratio B/A per row (``<cost>_a``, ``<cost>_b``, ``<cost>_ratio_b_over_a``), and the runs
    present in only one of the two as (side ``"A"`` or ``"B"``, run), sorted. A ratio is given only where both
    costs are finite and positive: a compile time of 0 or below (nothing compiled, or a cached compile: the
    first call was no slower than the others) or a missing cost (a failed run) has no meaningful ratio, and
    gives NaN. Runs of one name and other physics (``scene_differences``) never match.
    """
    import numpy as np
    import pandas as pd

    left = frame_a.assign(run=run_identity(frame_a, frame_b), scene=scene_labels(frame_a, frame_b))
    right = frame_b.assign(run=run_identity(frame_b, frame_a), scene=scene_labels(frame_b, frame_a))
    merged = left.merge(right, on=["run", "scene", "integrator"], suffixes=("_a", "_b"), how="inner")
    unmatched = sorted([("A", run) for run in set(left["run"]) - set(right["run"])]
                       + [("B", run) for run in set(right["run"]) - set(left["run"])])
    mismatches = []
    for column in DETERMINISTIC_COLUMNS:
        equal = _bits_equal(merged[f"{column}_a"], merged[f"{column}_b"])
        if column in OPTIONAL_VERDICT_COLUMNS:  # left out by one side's matrix: nothing to compare
            equal |= merged[f"{column}_a"].isna() | merged[f"{column}_b"].isna()
        mismatches += [{"run": run, "column": column, "a": a, "b": b}
                       for run, a, b in zip(merged["run"][~equal], merged[f"{column}_a"][~equal],
                                            merged[f"{column}_b"][~equal], strict=True)]
    costs = merged[["run", "scene", "integrator"]].copy()
    for column in COST_COLUMNS:
        cost_a, cost_b = merged[f"{column}_a"].astype(float), merged[f"{column}_b"].astype(float)
        comparable = np.isfinite(cost_a) & np.isfinite(cost_b) & (cost_a > 0) & (cost_b > 0)
        costs[f"{column}_a"], costs[f"{column}_b"] = cost_a, cost_b
        costs[f"{column}_ratio_b_over_a"] = (cost_b / cost_a).where(comparable)
    return pd.DataFrame(mismatches, columns=["run", "column", "a", "b"]), costs, unmatched
