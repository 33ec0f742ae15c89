"""Which rows of a results table a bound applies to, and whether a thresholds file fits a matrix's rows.

``select_rows`` picks a bound's rows (scene, integrator or family, setting; the setting match of
``bench.gate.thresholds``), ``counterpart_row`` the row a ``max_ratio`` bound divides by. ``validate_against``
finds every bound that names an unknown scene, integrator or family or selects nothing, on stored rows or on
the rows a matrix will produce (``planned_rows``), so bad input is reported before a matrix is run.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence, cast

import numpy as np
import pandas as pd

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.gate.thresholds import (
    MIN_ORDER_SETTINGS, SETTING_RELATIVE_TOLERANCE, Counterpart, Selection, Thresholds,
)
from foucault_bench.bench.schema import setting_label
from foucault_bench.bench.validation import short_list, short_repr, suggestion

if TYPE_CHECKING:  # for annotations only: bench.run.matrix imports the scenes and the integrators
    from foucault_bench.bench.run.matrix import Matrix


def as_float(value: Any) -> float:
    """A stored value as a float, NaN for a missing one (None, NaN, pandas' NA)."""
    return math.nan if value is None or pd.isna(value) else float(value)


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=SETTING_RELATIVE_TOLERANCE, abs_tol=0.0)


def effective_kh(row: pd.Series, requested_kh: float) -> float | None:
    """The kh the fixed-step loop runs when asked for ``requested_kh`` on the row's output grid
    (``integrators.fixed_step.uniform_output_stride``), or ``None`` when the row lacks the grid or the step."""
    from foucault_bench.integrators.fixed_step import uniform_output_stride

    n_out, duration, kh, step = (row.get(name) for name in ("n_out", "duration_s", "kh", "step_s"))
    if any(value is None or pd.isna(value) for value in (n_out, duration, kh, step)) or n_out < 2 or step <= 0:
        return None
    frequency = kh / step  # k in rad/s
    spacing = duration / (n_out - 1)
    _, step_run = uniform_output_stride(np.array([0.0, spacing]), requested_kh / frequency)
    return step_run * frequency


def _kh_matches(row: pd.Series, requested: float) -> bool:
    if pd.isna(row["kh"]):
        return False
    if _close(row["kh"], requested):
        return True
    effective = effective_kh(row, requested)
    return effective is not None and _close(row["kh"], effective)


def _setting_matches(row: pd.Series, kh: Sequence[float], tol: Sequence[float], kh_min: float | None,
                     kh_max: float | None) -> bool:
    if kh:
        return any(_kh_matches(row, value) for value in kh)
    if tol:
        return pd.notna(row["tol"]) and any(_close(row["tol"], value) for value in tol)
    if kh_min is not None or kh_max is not None:
        return pd.notna(row["kh"]) and (kh_min is None or row["kh"] >= kh_min) and \
            (kh_max is None or row["kh"] <= kh_max)
    return True


def select_rows(frame: pd.DataFrame, selection: Selection) -> pd.DataFrame:
    """The rows of ``frame`` (results-table columns) that ``selection`` picks, in frame order."""
    chosen = frame["scene"].isin(selection.scenes)
    if selection.family is not None:
        chosen &= frame["family"] == selection.family
    else:
        chosen &= frame["integrator"].isin(selection.integrators)
    candidates = frame[chosen]
    keep = [_setting_matches(row, selection.kh, selection.tol, selection.kh_min, selection.kh_max)
            for _, row in candidates.iterrows()]
    return candidates[np.array(keep, dtype=bool)] if len(candidates) else candidates


def counterpart_row(frame: pd.DataFrame, row: pd.Series, counterpart: Counterpart) -> pd.Series | None:
    """The row a ``max_ratio`` bound divides by: same scene, the other integrator, the row's or a fixed setting."""
    same = frame[(frame["scene"] == row["scene"]) & (frame["integrator"] == counterpart.integrator)]
    fixed = counterpart.kh is not None or counterpart.tol is not None
    kh, tol = (counterpart.kh, counterpart.tol) if fixed else (as_float(row["kh"]), as_float(row["tol"]))
    khs: tuple[float, ...] = (cast(float, kh),) if pd.notna(kh) else ()
    tols: tuple[float, ...] = (cast(float, tol),) if pd.notna(tol) else ()
    found = [other for _, other in same.iterrows() if _setting_matches(other, khs, tols, None, None)]
    return found[0] if found else None

def validate_against(thresholds: Thresholds, frame: pd.DataFrame, *, what: str) -> None:
    """Raise ``InputError`` for every bound that names an unknown scene, integrator or family, or selects no row
    of ``frame`` (``what`` names the rows in messages, e.g. "matrix 'quick'"), or whose sweep or counterpart
    is missing."""
    from foucault_bench.bench.problems.scenes import SCENES
    from foucault_bench.integrators import REGISTRY

    scenes = sorted(set(frame["scene"]))
    integrators = sorted(set(frame["integrator"]))
    known_scenes = set(SCENES) | set(scenes)
    known_integrators = set(REGISTRY) | set(integrators)
    known_families = {integrator.family for integrator in REGISTRY.values()} | set(frame["family"].dropna())
    problems = []
    for bound in thresholds.bounds:
        where = f"{thresholds.source}: bound #{bound.number} ({bound.label})"
        own = []
        for scene in bound.selection.scenes:
            if scene not in known_scenes:
                own.append(f"{where}: unknown scene {short_repr(scene)}{suggestion(scene, known_scenes)}")
            elif scene not in scenes:
                own.append(f"{where}: scene {short_repr(scene)} has no rows in {what} (its scenes: {short_list(scenes)})")
        names = list(bound.selection.integrators)
        if bound.relative_to is not None:
            names.append(bound.relative_to.integrator)
        for name in names:
            if name not in known_integrators:
                own.append(f"{where}: unknown integrator {short_repr(name)}{suggestion(name, known_integrators)}; "
                           f"known integrators: {', '.join(sorted(known_integrators))}")
            elif name not in integrators:
                own.append(f"{where}: integrator {short_repr(name)} has no rows in {what} "
                           f"(its integrators: {', '.join(integrators)})")
        family = bound.selection.family
        if family is not None and family not in known_families:
            own.append(f"{where}: unknown family {short_repr(family)}{suggestion(family, known_families)}; "
                       f"known families: {', '.join(sorted(known_families))}")
        if own:
            problems += own
            continue
        rows = select_rows(frame, bound.selection)
        if rows.empty:
            settings = sorted({setting_label(row["kh"], row["tol"]) for _, row in frame[
                frame["scene"].isin(bound.selection.scenes)].iterrows()})
            problems.append(f"{where}: matches no row of {what} (settings there: {short_list(settings)})")
        elif bound.kind == "min_order":
            problems += _sweep_problems(rows, where)
        elif bound.kind == "max_ratio":
            assert bound.relative_to is not None  # a max_ratio bound has one (thresholds._parse_bound)
            missing = sorted({f"{row['scene']} {setting_label(row['kh'], row['tol'])}" for _, row in rows.iterrows()
                              if counterpart_row(frame, row, bound.relative_to) is None})
            if missing:
                problems.append(f"{where}: {bound.relative_to.integrator} has no row to compare with at "
                                f"{short_list(missing)} in {what}")
    if problems:
        raise InputError(problems)


def _sweep_problems(rows: pd.DataFrame, where: str) -> list[str]:
    problems = []
    for (scene, integrator), group in rows.groupby(["scene", "integrator"], sort=False):
        if group["kh"].isna().any():
            problems.append(f"{where}: {integrator} is adaptive; an order is fitted across fixed-step settings only")
        elif len(group) < MIN_ORDER_SETTINGS:
            problems.append(f"{where}: {scene} {integrator}: an order needs a sweep of at least "
                            f"{MIN_ORDER_SETTINGS} step sizes, the rows hold {len(group)}")
    return problems


def planned_rows(matrix: "Matrix") -> pd.DataFrame:
    """The identity columns of the rows ``matrix`` will produce, as the runner fills them (``base_row``), with
    each fixed-step run's effective step (``uniform_output_stride`` on the scene's grid), its family and
    ``n_out``: enough to validate a thresholds file before anything runs."""
    from foucault_bench.bench.run.execute import base_row
    from foucault_bench.integrators.fixed_step import uniform_output_stride

    rows = []
    for spec in matrix.runs:
        row = base_row(spec, "planned")
        grid = spec.scene.output_grid()
        row["n_out"] = grid.size  # the family and the other declared facts are in base_row
        if spec.step_s is not None:
            _, row["step_s"] = uniform_output_stride(grid, spec.step_s)
            row["kh"] = row["step_s"] * spec.scene.params.pendulum_frequency_rad_s
        rows.append(row)
    return pd.DataFrame(rows)
