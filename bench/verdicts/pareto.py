"""Decisions from the results rows: Pareto fronts of cost against error, and the cheapest run at a target.

Plain data in, plain data out (DataFrames with the ``bench.schema`` columns; no plotting, no store), so the
report, the ``advise`` command and the tests share one definition:

* ``cost_column``: the cost every decision is made on: CPU time (``cpu_time_s``) where the results have it,
  else the median wall time (``wall_time_s``);
* ``pareto_front``: per scene, the runs no other run beats on both cost and error (across every integrator
  and setting), cheapest first: the lower-left envelope of a work-precision chart (the efficient frontier of
  Pareto optimality; as in DiffEqDevTools' work-precision sets, a run is a point, not a method);
* ``best_of_family``: per scene and integrator family, the family's most accurate run and how many of the
  scene's front runs are the family's;
* ``cheapest_meeting``: every run that meets a target, cheapest first, one per integrator and setting;
* ``matched_accuracy``: per scene and target, the cheapest run meeting it, the runner-up (the cheapest run of
  another integrator) and their cost ratio;
* ``ranked_at_targets``: per scene and target, every integrator's cheapest run meeting it, ranked by cost with its
  ratio to the cheapest, and the integrators that do not reach it with their best error.

Errors are compared as absolute values; a run counts only when its status is ok and both its cost and its
error are finite, with cost > 0 and error ≥ 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, Sequence

import numpy as np
import pandas as pd

from foucault_bench.bench.schema import setting_label
from foucault_bench.integrators import STATUS_OK
from foucault_bench.models import MODELS


@dataclass(frozen=True)
class ErrorMetric:
    """An error column a decision can be made on, and for which models it measures the integrator."""

    column: str
    title: str
    applies: Callable[[str], bool]
    why_not: str


def _conserves_energy(model: str) -> bool:
    return model in MODELS and MODELS[model].conserves_energy


ERROR_METRICS: dict[str, ErrorMetric] = {
    metric.column: metric for metric in (
        ErrorMetric("reference_error", "reference error", lambda model: True, ""),
        ErrorMetric("precession_rate_ref_error", "precession-rate error", lambda model: True, ""),
        ErrorMetric("energy_max_rel_error", "energy error", _conserves_energy,
                    "the model conserves no energy, so the energy error measures the model, not the run"),
        ErrorMetric("energy_drift_per_s", "energy drift (1/s)", _conserves_energy,
                    "the model conserves no energy, so the energy drift measures the model, not the run"),
        ErrorMetric("analytic_gap_exact", "analytic gap", lambda model: model == "linear",
                    "the exact solution is the linear model's: for another model the gap measures the model"),
    )
}
"""Metric name (= results column) → definition. Fronts and targets use these."""

DEFAULT_TARGETS: tuple[float, ...] = (1e-3, 1e-6, 1e-9, 1e-12)
"""Targets of the matched-accuracy table when none are given."""

COST_COLUMNS: tuple[str, ...] = ("cpu_time_s", "wall_time_s")
"""Preferred cost first: CPU time where the results have it, else wall time."""


def cost_column(frame: pd.DataFrame) -> str:
    """``cpu_time_s`` when ``frame`` has it with at least one value, else ``wall_time_s``."""
    for column in COST_COLUMNS[:-1]:
        if column in frame.columns and frame[column].notna().any():
            return column
    return COST_COLUMNS[-1]


def usable_runs(frame: pd.DataFrame, metric: str, cost: str | None = None) -> pd.DataFrame:
    """The ok runs with a finite cost > 0 and a finite error ≥ 0 in ``metric`` whose model the metric applies
    to, with two added columns: ``error`` (|metric|) and ``cost`` (the ``cost`` column, default
    ``cost_column``)."""
    cost = cost or cost_column(frame)
    definition = ERROR_METRICS[metric]
    error = frame[metric].abs()
    keep = ((frame["status"] == STATUS_OK) & np.isfinite(error) & np.isfinite(frame[cost]) & (frame[cost] > 0)
            & frame["model"].map(definition.applies).astype(bool))
    return frame[keep].assign(error=error[keep], cost=frame.loc[keep, cost])


def _front(runs: pd.DataFrame) -> pd.DataFrame:
    """Rows of ``runs`` (with ``cost`` and ``error``) that no other row beats on both: sort by cost, then
    error, and keep each row whose error is below every cheaper row's."""
    ordered = runs.sort_values(["cost", "error"], kind="stable")
    best_before = np.minimum.accumulate(np.concatenate(([np.inf], ordered["error"].to_numpy()[:-1])))
    return ordered[ordered["error"].to_numpy() < best_before]


def _identity(runs: pd.DataFrame, metric: str, cost: str) -> pd.DataFrame:
    return pd.DataFrame({
        "scene": runs["scene"], "metric": metric, "integrator": runs["integrator"], "family": runs["family"],
        "setting": [setting_label(kh, tol) for kh, tol in zip(runs["kh"], runs["tol"], strict=True)],
        "kh": runs["kh"], "tol": runs["tol"], "error": runs["error"], cost: runs["cost"],
    })


def pareto_front(frame: pd.DataFrame, metric: str = "reference_error") -> pd.DataFrame:
    """Per scene, the Pareto-efficient runs of ``metric`` against ``cost_column``, cheapest first.

    Columns: scene, metric, integrator, family, setting, kh, tol, error, <cost column>.
    """
    cost = cost_column(frame)
    runs = usable_runs(frame, metric, cost)
    fronts = [_front(group) for _, group in runs.groupby("scene", sort=True)]
    front = pd.concat(fronts) if fronts else runs.iloc[:0]
    return _identity(front, metric, cost).reset_index(drop=True)


def best_of_family(frame: pd.DataFrame, metric: str = "reference_error") -> pd.DataFrame:
    """Per scene and family: the family's most accurate run (its error, setting and cost) and how many of the
    scene's front points (``pareto_front``) the family holds."""
    cost = cost_column(frame)
    runs = usable_runs(frame, metric, cost)
    front_points = pareto_front(frame, metric).groupby(["scene", "family"]).size()
    rows = []
    for (scene, family), group in runs.groupby(["scene", "family"], sort=True):
        best = group.sort_values(["error", "cost"], kind="stable").iloc[0]
        rows.append({"scene": scene, "metric": metric, "family": family, "integrator": best["integrator"],
                     "setting": setting_label(best["kh"], best["tol"]), "error": best["error"], cost: best["cost"],
                     "front_points": int(front_points.get((scene, family), 0))})
    return pd.DataFrame(rows, columns=["scene", "metric", "family", "integrator", "setting", "error", cost,
                                       "front_points"])


def cheapest_meeting(frame: pd.DataFrame, metric: str, target: float) -> pd.DataFrame:
    """Every usable run with |metric| ≤ ``target``, cheapest first (ties: smaller error), repeated runs of one
    integrator and setting reduced to their cheapest. Columns as ``pareto_front``; the index is the runs'
    index in ``frame``."""
    cost = cost_column(frame)
    runs = usable_runs(frame, metric, cost)
    met = runs[runs["error"] <= target].sort_values(["cost", "error"], kind="stable")
    table = _identity(met, metric, cost)
    return table.drop_duplicates(["scene", "integrator", "setting"])


def matched_accuracy(frame: pd.DataFrame, metric: str = "reference_error",
                     targets: Sequence[float] = DEFAULT_TARGETS) -> pd.DataFrame:
    """Per scene and target: the cheapest run with |metric| ≤ target, the runner-up (the cheapest run of
    another integrator meeting it) and ``ratio`` = runner-up cost / cheapest cost; 'not reached' when no run
    meets the target, and an empty runner-up when only one integrator does."""
    cost = cost_column(frame)
    rows = []
    for scene in sorted(frame["scene"].unique()):
        scene_rows = frame[frame["scene"] == scene]
        for target in sorted(targets, reverse=True):
            met = cheapest_meeting(scene_rows, metric, target)
            row: dict[str, object] = {"scene": scene, "metric": metric, "target": float(target)}
            if met.empty:
                row.update(outcome="not reached", best_error=usable_runs(scene_rows, metric, cost)["error"].min())
            else:
                first = met.iloc[0]
                others = met[met["integrator"] != first["integrator"]]
                row.update(outcome="reached", integrator=first["integrator"], setting=first["setting"],
                           error=first["error"], cost=first[cost])
                if not others.empty:
                    second = others.iloc[0]
                    row.update(runner_up=second["integrator"], runner_up_setting=second["setting"],
                               runner_up_error=second["error"], runner_up_cost=second[cost],
                               ratio=second[cost] / first[cost])
            rows.append(row)
    columns = ["scene", "metric", "target", "outcome", "integrator", "setting", "error", "cost", "runner_up",
               "runner_up_setting", "runner_up_error", "runner_up_cost", "ratio", "best_error"]
    return pd.DataFrame(rows, columns=columns).rename(columns={"cost": cost, "runner_up_cost": f"runner_up_{cost}"})


def ranked_at_targets(frame: pd.DataFrame, metric: str = "reference_error",
                      targets: Sequence[float] = DEFAULT_TARGETS) -> pd.DataFrame:
    """Per scene, target and integrator of the scene: its cheapest run with |metric| ≤ target (``cheapest_meeting``),
    its ``rank`` among the integrators that meet it (1: the cheapest, the winner of ``matched_accuracy``) and
    ``ratio`` = its cost / the winner's; 'not reached' with its ``best_error`` (the smallest |metric| of its usable
    runs, empty when it has none) otherwise. Rows of a scene and target: ranked first, cheapest first, then the
    integrators that do not reach it by name."""
    cost = cost_column(frame)
    rows = []
    for scene in sorted(frame["scene"].unique()):
        scene_rows = frame[frame["scene"] == scene]
        usable = usable_runs(scene_rows, metric, cost)
        for target in sorted(targets, reverse=True):
            met = cheapest_meeting(scene_rows, metric, target).drop_duplicates("integrator")
            winner_cost = met[cost].iloc[0] if not met.empty else np.nan
            for rank, run in enumerate(met.itertuples(index=False), start=1):
                run_cost = getattr(run, cost)
                rows.append({"scene": scene, "metric": metric, "target": float(target), "rank": rank,
                             "integrator": run.integrator, "family": run.family, "outcome": "reached",
                             "setting": run.setting, "error": run.error, cost: run_cost,
                             "ratio": run_cost / winner_cost})
            for integrator in sorted(set(scene_rows["integrator"]) - set(met["integrator"])):
                own = usable[usable["integrator"] == integrator]["error"]
                family = scene_rows.loc[scene_rows["integrator"] == integrator, "family"].iloc[0]
                rows.append({"scene": scene, "metric": metric, "target": float(target), "integrator": integrator,
                             "family": family, "outcome": "not reached",
                             "best_error": own.min() if not own.empty else np.nan})
    columns = ["scene", "metric", "target", "rank", "integrator", "family", "outcome", "setting", "error", cost,
               "ratio", "best_error"]
    return pd.DataFrame(rows, columns=columns)


def metrics_present(frame: pd.DataFrame) -> list[str]:
    """The ``ERROR_METRICS`` with at least one usable run in ``frame``."""
    return [metric for metric in ERROR_METRICS if metric in frame.columns and not usable_runs(frame, metric).empty]


def all_fronts(frame: pd.DataFrame, metrics: Iterable[str] | None = None) -> pd.DataFrame:
    """``pareto_front`` of every metric (default: ``metrics_present``) in one table."""
    parts = [pareto_front(frame, metric) for metric in (metrics_present(frame) if metrics is None else metrics)]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
