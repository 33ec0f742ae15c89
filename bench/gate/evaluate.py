"""Evaluating the bounds of a thresholds file on a results table: one outcome per bound and row.

The margin of an outcome (``headroom``) is the headroom factor when the bound and the measured value are both
positive (bound ÷ measured for an upper bound, measured ÷ bound for a lower one; below 1 fails), otherwise the
difference (bound − measured, or measured − bound; below 0 fails). A ``min_order`` bound is checked on the
convergence order fitted across a fixed-step sweep (``bench.verdicts.convergence.observed_order``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import pandas as pd

from foucault_bench.bench.gate.select import as_float, counterpart_row, select_rows
from foucault_bench.bench.gate.thresholds import UPPER_BOUNDS, Bound, Thresholds
from foucault_bench.bench.schema import OPTIONAL_VERDICT_COLUMNS, setting_label


@dataclass(frozen=True)
class Outcome:
    """One checked line: a bound on one row (or, for ``min_order``, on one scene × integrator sweep)."""

    bound: Bound
    scene: str
    integrator: str
    setting: str
    measured: float | str
    margin: float | None
    passed: bool
    detail: str = ""
    margin_is_factor: bool = False


def headroom(kind: str, measured: float, limit: float) -> tuple[float, bool]:
    """The margin of the module docstring and whether it is a factor (both numbers positive) rather than a
    difference."""
    upper = kind in UPPER_BOUNDS
    if measured > 0 and limit > 0:
        return (limit / measured if upper else measured / limit), True
    return (limit - measured if upper else measured - limit), False


def _holds(kind: str, measured: float, limit: float) -> bool:
    return measured <= limit if kind in UPPER_BOUNDS else measured >= limit


def _not_ok(row: pd.Series) -> str:
    message = row["message"] if isinstance(row["message"], str) and row["message"] else "no message"
    return f"run {row['status']}: {message}"


def evaluate(thresholds: Thresholds, frame: pd.DataFrame) -> list[Outcome]:
    """Check every bound on ``frame`` (the results table of one matrix run, already validated with
    ``validate_against``); one outcome per bound and row (per scene × integrator for ``min_order``)."""
    from foucault_bench.bench.verdicts.convergence import observed_order

    outcomes = []
    for bound in thresholds.bounds:
        rows = select_rows(frame, bound.selection)
        if bound.kind == "min_order":
            for (scene, integrator), group in rows.groupby(["scene", "integrator"], sort=False):
                order = observed_order(group["step_s"].to_numpy(dtype=float),
                                       group[bound.column].to_numpy(dtype=float))
                settings = f"kh={group['kh'].min():.4g}..{group['kh'].max():.4g} ({len(group)} steps)"
                not_ok = group[group["status"] != "ok"]
                detail = f"{len(not_ok)} of the runs not ok (left out of the fit)" if len(not_ok) else ""
                outcomes.append(_numeric_outcome(bound, scene, integrator, settings, order, detail))
            continue
        for _, row in rows.iterrows():
            setting = setting_label(row["kh"], row["tol"])
            if bound.kind == "status":
                passed = row["status"] == bound.limit
                outcomes.append(Outcome(bound, row["scene"], row["integrator"], setting, row["status"], None, passed,
                                        "" if passed or row["status"] == "ok" else _not_ok(row)))
                continue
            if row["status"] != "ok":
                outcomes.append(Outcome(bound, row["scene"], row["integrator"], setting, f"({row['status']})", None,
                                        False, _not_ok(row)))
                continue
            value = as_float(row[bound.column])
            detail = ""
            if bound.kind == "max_abs":
                value = abs(value)
            elif bound.kind == "max_ratio":
                assert bound.relative_to is not None  # a max_ratio bound has one (thresholds._parse_bound)
                other = counterpart_row(frame, row, bound.relative_to)
                assert other is not None  # refused before evaluating (select.validate_against)
                other_value = as_float(other[bound.column])
                detail = (f"{bound.relative_to.integrator} {setting_label(other['kh'], other['tol'])}: "
                          f"{other_value:.3g}")
                if other["status"] != "ok":
                    value, detail = math.nan, f"{bound.relative_to.integrator}'s {_not_ok(other)}"
                else:
                    value = value / other_value if other_value > 0 else math.nan
            outcomes.append(_numeric_outcome(bound, row["scene"], row["integrator"], setting, value, detail))
    return outcomes

def _numeric_outcome(bound: Bound, scene: str, integrator: str, setting: str, value: float,
                     detail: str) -> Outcome:
    if not math.isfinite(value):
        where = OPTIONAL_VERDICT_COLUMNS.get(bound.column or "")  # a column computed only where a matrix asks
        missing = f"no finite value measured ({bound.column}: {where})" if where else "no finite value measured"
        detail = "; ".join(filter(None, [detail, missing]))
        return Outcome(bound, scene, integrator, setting, value, None, False, detail)
    limit = cast(float, bound.limit)  # a number for every kind but status
    margin, is_factor = headroom(bound.kind, value, limit)
    return Outcome(bound, scene, integrator, setting, value, margin, _holds(bound.kind, value, limit), detail,
                   is_factor)
