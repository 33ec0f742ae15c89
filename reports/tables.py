"""The report's tables, derived from the results rows (columns of ``bench.schema``) as plain DataFrames.

* ``matched_accuracy``: per scene and target (1e-3, 1e-6, 1e-9, 1e-12 or the targets given), the cheapest integrator
  and setting whose reference error meets it, the runner-up and the cost ratio (``bench.verdicts.pareto``);
* ``ranked_at_targets``: per scene and target, every integrator's cheapest setting meeting it, ranked by cost with
  its ratio to the cheapest, or "not reached" with its best error;
* ``per_integrator``: one row per (scene, integrator): the cheapest setting whose reference error reaches
  ``target`` (1e-6 by default), its cost, or "not reached"; run counts by status;
* ``fronts`` / ``families``: the Pareto-efficient runs of every error metric, and the best run of each family
  present (or why it has none);
* ``scenes_table``: what each scene is (place, pendulum, release, grid, model and why, source; for an inline
  scene of a matrix file, the model, duration and grid its rows hold).
* ``convergence_orders``: the observed order of each fixed-step integrator per scene
  (``bench.verdicts.convergence.observed_order``) next to its declared order.
* ``compact_table`` / ``full_table``: the tidy results, a readable subset and every column.

Every table keeps a row for every integrator present in the results, with the counts of ok, diverged and
failed runs, so a run that failed appears with its status instead of vanishing. ``COLUMN_NOTES`` states each
column's unit and meaning (from ``bench.schema`` plus the derived columns defined here); ``COLUMN_FORMATS``
how a column is printed (``reports.document.display_frame``).
"""

from __future__ import annotations

from typing import Iterator, Sequence

import numpy as np
import pandas as pd

from foucault_bench.bench.schema import COLUMN_NAMES, COLUMNS, RUN_STATUSES
from foucault_bench.bench.problems.scenes import Scene
from foucault_bench.bench.verdicts import pareto
from foucault_bench.bench.verdicts.convergence import observed_order_fit
from foucault_bench.bench.verdicts.pareto import DEFAULT_TARGETS, ERROR_METRICS, cheapest_meeting, cost_column
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_OK
from foucault_bench.integrators.registry import REGISTRY

MATCHED_ACCURACY_TARGET = 1e-6
"""Reference error (max |r − r_ref| / A) a setting must reach to count in the matched-accuracy summary."""

STATUSES = RUN_STATUSES

DERIVED_NOTES: dict[str, str] = {
    "runs": "runs stored for this scene and integrator",
    "ok": "runs that finished",
    "diverged": "runs whose state left the bounds or became non-finite",
    "failed": "runs that raised an error (message in `note`)",
    "timeout": "runs stopped at the per-run time limit",
    "outcome": "per integrator: whether an ok run reached the target; per family: its best run, or 'no usable "
               "run' (no ok run with a finite error and a cost > 0) with its runs by status",
    "setting": "step as k·h (fixed-step) or tolerance (adaptive)",
    "note": "first diverged/failed message of this scene and integrator",
    "metric": "error column the row is about (bench.verdicts.pareto.ERROR_METRICS)",
    "target": "largest error accepted",
    "error": "|metric| of the run",
    "runner_up": "cheapest integrator other than the winner meeting the target",
    "runner_up_setting": "its setting",
    "runner_up_error": "its error",
    "ratio": "runner-up cost / winner cost (≥ 1: how much the winner saves); in the ranking at matched accuracy, "
             "this integrator's cost / the cheapest one's",
    "rank": "1 for the cheapest integrator meeting the target, 2 for the next, …; empty when not reached",
    "best_error": "smallest error any ok run reached (when the target is not reached)",
    "front_points": "runs of the family on the scene's Pareto front",
    "runner_up_cpu_time_s": "s; runner-up's CPU time",
    "runner_up_wall_time_s": "s; runner-up's median wall time",
    "declared_order": "classical order the integrator declares (empty: varies)",
    "place": "where the pendulum is (or what the scene is for)",
    "length_m": "m; string length L",
    "latitude_deg": "°; geographic latitude φ, north positive",
    "amplitude_m": "m; horizontal distance A of the release point from the vertical",
    "release_azimuth_deg": "°; direction of the release point from x (South) towards y (East)",
    "release": "initial velocity in the rotating frame",
    "output_interval_s": "s; spacing of the output grid shared by every integrator",
    "why_model": "why the scene's model is enough (bench.verdicts.adequacy measures the others)",
    "source": "where the scene's numbers come from",
    "kind": "fixed-step (fitted) or adaptive (no step size to fit against)",
    "fitted_order": "slope of log(reference_error) against log(step_s) by bench.verdicts.convergence."
                    "observed_order: of the ok runs with a finite error ≤ 0.1 (larger ones have saturated), the "
                    "finest steps (at most 4) of the longest stretch whose local slopes agree; empty when no "
                    "stretch qualifies",
    "points": "distinct steps that fit used (0: no fit, e.g. every error saturated)",
    "energy_error_first_hour": "max |E − E₀| / E_swing over t ≤ 1 h",
    "energy_error_end": "|E − E₀| / E_swing at the last finite output time",
    "end_s": "s; last output time with a finite state",
    "stability_limit_kh": "largest stable k·h the integrator declares (empty: unstable for every h)",
    "first_diverged_kh": "smallest k·h of the sweep whose run diverged within the sweep's steps",
    "largest_kh_not_diverged": "largest k·h of the sweep below first_diverged_kh",
    "simpler_model": "the simpler model of the pair (bench.verdicts.adequacy)",
    "scene_model": "the scene's own model",
    "precession_rate_diff": "(rate of simpler − rate of richer model) / (Ω_E|sin φ|), signed",
    "trajectory_gap": "max over the grid of |r_simpler − r_richer| / A",
    "expected_rate_diff": "leading-order expectation of precession_rate_diff (Airy term), empty where none",
    "expected_trajectory_gap": "leading-order expectation of trajectory_gap, empty where none",
}
COLUMN_NOTES: dict[str, str] = {
    **{c.name: (f"{c.unit}; " if c.unit else "") + c.description for c in COLUMNS},
    **DERIVED_NOTES,
}
INTEGER_COLUMNS: frozenset[str] = frozenset(
    {c.name for c in COLUMNS if c.sql_type == "INTEGER"} | {"runs", "ok", "diverged", "failed", "timeout", "rank", "points"})
KH_FORMAT = ".4g"
"""k·h with four significant digits, as ``bench.schema.setting_label`` writes a setting (``kh=0.2726``), so a
setting quoted in a summary is found as it is in the tables."""
KH_COLUMNS: frozenset[str] = frozenset({"kh", "stability_limit_kh", "declared_limit_kh", "measured_limit_kh",
                                        "first_diverged_kh", "kh_below_limit", "largest_kh_not_diverged"})
ORDER_FORMAT = ".2f"
"""A fitted order with two decimals, as the convergence charts' legends write it (``fitted order 6.00``)."""
RATE_DEG_H_FORMAT = ".2f"
"""A precession rate in °/h with two decimals, the resolution the real halls' sources quote (Guelph's measured 10.38
against its predicted 10.36; three significant digits would print both as 10.4)."""
RATE_DEG_H_COLUMNS = ("measured_deg_h", "ideal_deg_h", "with_effect_deg_h", "with_effect_long_time_deg_h")
"""The rate columns of the table "Against the measurement" (``reports.halls.against_measurement``)."""
COLUMN_FORMATS: dict[str, str] = {
    **{column: ".0f" for column in INTEGER_COLUMNS}, **{column: KH_FORMAT for column in KH_COLUMNS},
    **{column: RATE_DEG_H_FORMAT for column in RATE_DEG_H_COLUMNS}, "fitted_order": ORDER_FORMAT,
}
"""Column → format specification of its printed cells (``reports.document.display_frame``; other reals: three
significant digits)."""

COMPACT_COLUMNS: tuple[str, ...] = (
    "scene", "model", "integrator", "family", "kh", "tol", "status", "reference_error", "energy_max_rel_error",
    "precession_rate_ref_error", "precession_rate_error", "analytic_gap_exact", "cpu_time_s", "cpu_time_spread_s",
    "wall_time_s", "steps", "nfev", "message",
)
"""The "All runs" table: identity, outcome, verdicts, and the costs: CPU time (what every decision uses) with its
spread over the repeats, wall time, accepted steps (the charts' second cost axis) and evaluations."""


ADEQUACY_NOTES: dict[str, str] = {
    "model": "the richer model of the pair",
    "note": "remark of bench.verdicts.adequacy on this pair",
}
"""Meanings that differ in the adequacy table (``bench.verdicts.adequacy.model_adequacy``)."""


def notes_for(frame: pd.DataFrame, overrides: dict[str, str] | None = None) -> dict[str, str]:
    """Unit and meaning of each column of ``frame`` (``overrides`` first, then ``COLUMN_NOTES``)."""
    notes = {**COLUMN_NOTES, **(overrides or {})}
    return {column: notes[column] for column in frame.columns if column in notes}


def _status_counts(statuses: Sequence[object], messages: Sequence[object]) -> dict[str, object]:
    """The runs of a group (its rows' ``status`` and ``message``, in row order) counted by status, and the first
    non-empty message of a run that is not ok as its note."""
    counts: dict[str, object] = {"runs": len(statuses)}
    counts.update({status: sum(1 for value in statuses if value == status) for status in STATUSES})
    counts["note"] = next((str(message) for status, message in zip(statuses, messages, strict=True)
                           if status != STATUS_OK and not pd.isna(message) and str(message) != ""), "")
    return counts


def _groups(frame: pd.DataFrame) -> Iterator[tuple[tuple[str, str], pd.DataFrame, dict[str, object]]]:
    """Each (scene, integrator) group of ``frame``, sorted, with its ``_status_counts``."""
    statuses, messages = frame["status"].to_numpy(object), frame["message"].to_numpy(object)
    positions = frame.groupby(["scene", "integrator"]).indices
    for key in sorted(positions):
        rows = positions[key]
        yield key, frame.iloc[rows], _status_counts(statuses[rows], messages[rows])


def per_integrator(frame: pd.DataFrame, target: float = MATCHED_ACCURACY_TARGET) -> pd.DataFrame:
    """One row per (scene, integrator): the cheapest setting (``pareto.cost_column``) with reference_error ≤
    ``target``, its cost, or why none reached it; the run counts by status."""
    cost = cost_column(frame)
    # the cheapest run meeting the target, per group: a group's rows of the whole frame's cheapest_meeting are its
    # own cheapest_meeting (a filter and a stable sort of its rows), the first one its cheapest
    cheapest = {(run.scene, run.integrator): run for run in cheapest_meeting(frame, "reference_error", target)
                .drop_duplicates(["scene", "integrator"]).itertuples(index=False)}
    rows = []
    for (scene, integrator), group, counts in _groups(frame):
        ok = group[group["status"] == STATUS_OK]
        best = cheapest.get((scene, integrator))
        row = {"scene": scene, "integrator": integrator, "family": group["family"].iloc[0]}
        if best is not None:
            at = ok[ok["reference_error"].abs() == best.error].iloc[0]
            row.update(outcome="reached", setting=best.setting, reference_error=best.error,
                       **{cost: getattr(best, cost)}, nfev=at["nfev"])
        else:
            outcome = "not reached" if not ok.empty else f"no ok run ({', '.join(sorted(set(group['status'])))})"
            row.update(outcome=outcome, setting="", reference_error=ok["reference_error"].abs().min(),
                       **{cost: np.nan}, nfev=np.nan)
        row.update(counts)
        rows.append(row)
    columns = ["scene", "integrator", "family", "outcome", "setting", "reference_error", cost, "nfev",
               "runs", "ok", "diverged", "failed", "timeout", "note"]
    return pd.DataFrame(rows, columns=columns)


def matched_accuracy(frame: pd.DataFrame, targets: Sequence[float] = DEFAULT_TARGETS,
                     metric: str = "reference_error") -> pd.DataFrame:
    """Per scene and target: the cheapest integrator and setting meeting it, the runner-up (cheapest run of
    another integrator) and the cost ratio (``bench.verdicts.pareto.matched_accuracy``)."""
    return pareto.matched_accuracy(frame, metric, targets)


def ranked_at_targets(frame: pd.DataFrame, targets: Sequence[float] = DEFAULT_TARGETS,
                      metric: str = "reference_error") -> pd.DataFrame:
    """Per scene and target: every integrator's cheapest setting meeting it, its rank by cost and its cost over the
    cheapest one's, or 'not reached' (``bench.verdicts.pareto.ranked_at_targets``)."""
    return pareto.ranked_at_targets(frame, metric, targets)


def fronts(frame: pd.DataFrame) -> pd.DataFrame:
    """The Pareto-efficient runs of every error metric with values, per scene, cheapest first."""
    return pareto.all_fronts(frame)


def families(frame: pd.DataFrame) -> pd.DataFrame:
    """Per scene, metric and family present in the scene: the family's most accurate run and its share of the
    front (``pareto.best_of_family``), or a row saying it has no usable run, with its run counts by status.
    Metrics: the reference error always, the others where some run has a value; a metric gets rows only in
    scenes whose model it measures the integrator on (``pareto.ERROR_METRICS``)."""
    metrics = ["reference_error"] + [metric for metric in pareto.metrics_present(frame) if metric != "reference_error"]
    cost = cost_column(frame)
    parts = []
    for metric in metrics:
        best = pareto.best_of_family(frame, metric)
        found = {(row["scene"], row["family"]): row for row in reversed(best.to_dict("records"))}  # the first
        rows = []
        for (scene, family), group in frame.groupby(["scene", "family"], sort=True):
            if (scene, family) in found:
                rows.append({**found[(scene, family)], "outcome": "best run"})
            elif group["model"].map(ERROR_METRICS[metric].applies).astype(bool).any():
                counts = group["status"].value_counts()
                statuses = ", ".join(f"{counts[status]} {status}" for status in STATUSES if status in counts)
                rows.append({"scene": scene, "metric": metric, "family": family, "integrator": "",
                             "setting": "", "error": np.nan, cost: np.nan, "front_points": 0,
                             "outcome": f"no usable run ({statuses})"})
        parts.append(pd.DataFrame(rows, columns=["scene", "metric", "family", "outcome", "integrator", "setting",
                                                 "error", cost, "front_points"]))
    return pd.concat(parts, ignore_index=True)


def convergence_orders(frame: pd.DataFrame) -> pd.DataFrame:
    """Per (scene, integrator): declared order and the order fitted on the ok fixed-step runs' reference error
    against step size (``bench.verdicts.convergence.observed_order``; needs two or more distinct steps), with
    the number of points that fit used."""
    rows = []
    for (scene, integrator), group, counts in _groups(frame):
        registered = REGISTRY.get(integrator)
        fixed = group[group["tol"].isna() & (group["status"] == STATUS_OK)]
        usable = fixed[(fixed["reference_error"] > 0) & np.isfinite(fixed["reference_error"]) & (fixed["step_s"] > 0)]
        adaptive = bool(group["tol"].notna().all())
        fitted, points = np.nan, 0
        if not adaptive:
            fitted, points = observed_order_fit(usable["step_s"].to_numpy(float),
                                                usable["reference_error"].to_numpy(float))
        rows.append({
            "scene": scene, "integrator": integrator, "family": group["family"].iloc[0],
            "declared_order": None if registered is None else registered.order,
            "kind": "adaptive" if adaptive else "fixed-step", "fitted_order": fitted,
            "points": points, **counts,
        })
    return pd.DataFrame(rows)


def orders_by_integrator(orders: pd.DataFrame, scene: str) -> dict[str, float]:
    """integrator → fitted order (float) for one scene, from ``convergence_orders``."""
    rows = orders[orders["scene"] == scene]
    return {row.integrator: float(row.fitted_order) for row in rows.itertuples() if row.kind == "fixed-step"}


def scenes_table(scenes: Sequence[Scene], runs: pd.DataFrame | None = None) -> pd.DataFrame:
    """One row per scene: place, pendulum, release, duration and output grid, model, source and why that model
    (last: the page folds it under each row, ``Table.details``). A scene of
    ``runs`` without a ``Scene`` (an inline scene of a matrix file the report cannot see) gets a row saying so,
    with the model, duration and output interval (duration / (n_out − 1)) its rows hold."""
    rows = []
    for scene in scenes:
        params = scene.params
        moving = params.release_velocity_m_s != (0.0, 0.0)
        rows.append({
            "scene": scene.name, "place": scene.title, "length_m": params.length_m,
            "latitude_deg": params.latitude_deg, "amplitude_m": params.amplitude_m,
            "release_azimuth_deg": params.release_azimuth_deg,
            "release": f"moving at {params.release_velocity_m_s} m/s" if moving else "from rest",
            "duration_s": scene.duration_s, "output_interval_s": scene.output_interval_s, "model": scene.model,
            "why_model": scene.why_model, "source": scene.source,
        })
    known = {scene.name for scene in scenes}
    inline = runs[~runs["scene"].isin(known)] if runs is not None else pd.DataFrame(columns=list(COLUMN_NAMES))
    for name, scene_runs in inline.groupby("scene", sort=True):
        rows.append({
            "scene": name, "place": "inline scene of a matrix file (place and pendulum in that file)",
            "duration_s": _agreed(scene_runs["duration_s"]), "model": _agreed(scene_runs["model"]),
            "output_interval_s": _agreed(scene_runs["duration_s"] / (scene_runs["n_out"] - 1)),
        })
    return pd.DataFrame(rows, columns=["scene", "place", "length_m", "latitude_deg", "amplitude_m",
                                       "release_azimuth_deg", "release", "duration_s", "output_interval_s",
                                       "model", "source", "why_model"])


def _agreed(values: pd.Series) -> object:
    """The one value ``values`` hold (NaN when none); several distinct values listed as text, never one picked."""
    distinct = sorted(values.dropna().unique(), key=str)
    if len(distinct) <= 1:
        return distinct[0] if distinct else np.nan
    return ", ".join(f"{value:g}" if isinstance(value, float) else str(value) for value in distinct)


def _sorted_rows(frame: pd.DataFrame) -> pd.DataFrame:
    return frame.sort_values(["scene", "integrator", "step_s", "tol"], na_position="last").reset_index(drop=True)


def full_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Every column of the results, one row per run, sorted by scene, integrator and setting."""
    return _sorted_rows(frame)[list(COLUMN_NAMES)]


def compact_table(frame: pd.DataFrame) -> pd.DataFrame:
    """The identity, outcome, main verdicts and cost of every run (``COMPACT_COLUMNS``)."""
    return _sorted_rows(frame)[list(COMPACT_COLUMNS)]


# --------------------------------------------------------------------------------------------------------------
# summaries of the study tables
# --------------------------------------------------------------------------------------------------------------
def long_time_summary(energy: pd.DataFrame) -> pd.DataFrame:
    """Per run of the long-time energy study: status, max error over the first hour, error at the end."""
    rows = []
    for (integrator, setting), run in energy.groupby(["integrator", "setting"], sort=True):
        error = run["energy_rel_error"].abs()
        finite = run[error.notna()]
        rows.append({
            "integrator": integrator, "family": run["family"].iloc[0], "setting": setting,
            "status": run["status"].iloc[0],
            "energy_error_first_hour": error[run["t_s"] <= 3600.0].max(),
            "energy_error_end": abs(finite["energy_rel_error"].iloc[-1]) if not finite.empty else np.nan,
            "end_s": finite["t_s"].iloc[-1] if not finite.empty else np.nan,
            "message": run["message"].iloc[0],
        })
    return pd.DataFrame(rows)


def stability_summary(stability: pd.DataFrame) -> pd.DataFrame:
    """Per integrator and rotation setting of the stability sweep: the declared limit, the measured one (where
    the one-step map starts to grow), the first k·h whose long run diverged (the fixed-step loop's criterion:
    non-finite, or farther than 1000 L from the vertical), and the growth per step at the largest k·h below
    the declared limit (measured, and from the method's growth law where it declares one)."""
    rows = []
    for (integrator, rotation), sweep in stability.groupby(["integrator", "rotation"], sort=True):
        sweep = sweep.sort_values("kh")
        diverged = sweep.loc[sweep["status"] == STATUS_DIVERGED, "kh"]
        declared = sweep["stability_limit_kh"].iloc[0]
        below = sweep[sweep["kh"] < declared] if np.isfinite(declared) else sweep.iloc[0:0]
        last = below.iloc[-1] if not below.empty else None
        rows.append({
            "integrator": integrator, "family": sweep["family"].iloc[0],
            "rotation": "Ω_E sidereal" if rotation else "none",
            "declared_limit_kh": declared,
            "measured_limit_kh": sweep["measured_limit_kh"].iloc[0],
            "first_diverged_kh": diverged.min() if not diverged.empty else np.nan,
            "kh_below_limit": np.nan if last is None else last["kh"],
            "growth_per_step": np.nan if last is None else last["growth_per_step"],
            "growth_theory": np.nan if last is None else last["growth_theory"],
        })
    return pd.DataFrame(rows)