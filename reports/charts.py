"""The report's static charts of results rows: work-precision (each verdict against time and accepted steps),
convergence (reference error against k·h) and tolerance (achieved error against requested tolerance), one scene
each, written as PNG and SVG for papers. Nothing here computes a result; ``bench.verdicts`` and
``reports.tables`` do. Conventions (colours, markers, edge markers): ``reports.chart_style``.

Work-precision charts: cost = CPU time where the results have it, else wall time
(``bench.verdicts.pareto.cost_column``), its precision as horizontal bars (the 95 % confidence interval of the
median CPU time; the spread of the repeats for wall time), the Pareto envelope as a grey staircase, each line's
finest setting written at its end. ``reports.interactive`` draws the same charts for the HTML page from the same
``chart_style.sweeps``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from foucault_bench.bench.verdicts.pareto import cost_column
from foucault_bench.integrators.registry import REGISTRY
from foucault_bench.reports.chart_style import (
    outcome_legend_handles,
    plot_front,
    plot_sweeps,
    save,
    set_log_scales,
    sweeps,
)


VERDICT_LABELS: dict[str, tuple[str, str]] = {
    "reference_error": ("reference error", "max |r − r_ref| / A"),
    "energy_max_rel_error": ("energy error", "max |E − E₀| / E_swing"),
    "energy_drift_per_s": ("energy drift", "|slope of (E − E₀) / E_swing against t| (1/s)"),
    "precession_rate_ref_error": ("precession-rate error", "|rate − rate_ref| / (Ω_E |sin φ|)"),
    "analytic_gap_exact": ("analytic gap", "max |r − r_exact, linear| / A"),
}
"""Verdict column → (short title, axis label) for the work-precision charts (absolute values are plotted)."""

COST_LABELS: dict[str, str] = {
    "cpu_time_s": "CPU time per run (s): median of the timed repeats, bar = its 95 % confidence interval",
    "wall_time_s": "wall time per run (s): median of the timed repeats, bar = max − min",
    "steps": "accepted steps (one step = s RHS evaluations for Runge-Kutta,\n"
             "one corrector solve for multistep, one order-p Taylor expansion for heyoka)",
}
"""Cost column → axis label of the work-precision charts. Steps are counted for every family, so no method is
drawn on an axis whose unit does not apply to it (a Taylor step is not a right-hand-side evaluation); what a
step costs differs by family, which the time panel shows."""
CPU_TIME_CI95_WIDTH = "cpu_time_ci95_width_s"
"""Derived column (``with_cost_bars``): the full width (s) of the 95 % confidence interval of the median CPU
time, 2 · ``cpu_time_ci95_rel`` · ``cpu_time_s`` (the stated precision of the cost; NaN where not established)."""
COST_SPREADS: dict[str, str] = {"cpu_time_s": CPU_TIME_CI95_WIDTH, "wall_time_s": "wall_time_spread_s"}
"""Cost column → the column holding the total length of its error bar: the 95 % confidence interval of the
median for CPU time, the spread (max − min) of the timed repeats for wall time."""


def with_cost_bars(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` with ``CPU_TIME_CI95_WIDTH`` added (NaN where a row has no stated precision, e.g. an older
    database's rows)."""
    relative = frame["cpu_time_ci95_rel"] if "cpu_time_ci95_rel" in frame else np.nan
    return frame.assign(**{CPU_TIME_CI95_WIDTH: 2.0 * pd.to_numeric(relative) * frame["cpu_time_s"].astype(float)})


def cost_axes(frame: pd.DataFrame) -> tuple[str, str]:
    """The two cost axes of a work-precision chart: time (``pareto.cost_column``) and accepted steps."""
    return cost_column(frame), "steps"


def work_precision(scene_frame: pd.DataFrame, verdict: str, front: pd.DataFrame, stem: Path) -> Path:
    """``work_precision_figure`` saved under ``stem``."""
    return save(work_precision_figure(scene_frame, verdict, front), stem)


def work_precision_figure(scene_frame: pd.DataFrame, verdict: str, front: pd.DataFrame) -> Figure:
    """Verdict against time and against accepted steps for one scene, one line per integrator,
    fixed-step and tolerance sweeps on the same axes, the time's precision as bars, the Pareto envelope
    (``front``: ``bench.verdicts.pareto.pareto_front`` rows of this scene and verdict, may be empty) on the
    time panel."""
    scene = scene_frame["scene"].iloc[0]
    title, label = VERDICT_LABELS[verdict]
    figure = Figure(figsize=(13.5, 5.2), layout="constrained")
    axes_pair = figure.subplots(1, 2, sharey=True)
    handles = []
    time_cost = cost_axes(scene_frame)[0]
    scene_frame = with_cost_bars(scene_frame)
    for axes, cost in zip(axes_pair, cost_axes(scene_frame), strict=True):
        handles = plot_sweeps(axes, scene_frame, cost, verdict, x_spread=COST_SPREADS.get(cost),
                              labels=cost == time_cost)
        set_log_scales(axes)
        axes.set_xlabel(COST_LABELS[cost])
        axes.grid(True, which="major", alpha=0.3)
    envelope = plot_front(axes_pair[0], front, time_cost)
    axes_pair[0].set_ylabel(label)
    figure.suptitle(f"{scene}: {title} against cost (lower left is better)", fontsize=12)
    extra = [envelope] if envelope is not None else []
    figure.legend(handles=handles + extra + outcome_legend_handles(), loc="outside right upper", fontsize=9)
    return figure


def reference_slopes(fixed: pd.DataFrame, points: dict[str, pd.DataFrame]) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """(order, kh, error) of a reference line of slope p for each declared order p of the fixed-step
    integrators in ``fixed``: through the finest point of the first integrator of that order, at ¼ of its error,
    over that integrator's range of kh."""
    lines = []
    for order in sorted({order for name in fixed["integrator"].unique()
                         if name in REGISTRY and (order := REGISTRY[name].order)}):
        for name, rows in points.items():
            if name in REGISTRY and REGISTRY[name].order == order and len(rows) >= 2:
                kh = rows["kh"].to_numpy(float)
                finest = int(np.argmin(kh))
                span = np.array([kh.min(), kh.max()])
                lines.append((order, span, 0.25 * rows["reference_error"].to_numpy(float)[finest]
                              * (span / kh[finest]) ** order))
                break
    return lines


def convergence(scene_frame: pd.DataFrame, orders: dict[str, float], stem: Path) -> Path:
    """``convergence_figure`` saved under ``stem``."""
    return save(convergence_figure(scene_frame, orders), stem)


def convergence_figure(scene_frame: pd.DataFrame, orders: dict[str, float]) -> Figure:
    """Reference error against k·h for the fixed-step integrators of one scene, with a reference slope for each
    declared order; ``orders`` maps an integrator to its fitted order (shown in the legend)."""
    scene = scene_frame["scene"].iloc[0]
    fixed = scene_frame[scene_frame["tol"].isna()]
    figure = Figure(figsize=(9.5, 5.2), layout="constrained")
    axes = figure.subplots()
    handles = plot_sweeps(axes, fixed, "kh", "reference_error")
    for handle, sweep in zip(handles, sweeps(fixed, "kh", "reference_error"), strict=True):
        order = orders.get(sweep.integrator)
        fitted = "no fit" if order is None or not np.isfinite(order) else f"fitted order {order:.2f}"
        handle.set_label(f"{handle.get_label()}, {fitted}")
    points = {sweep.integrator: sweep.points for sweep in sweeps(fixed, "kh", "reference_error")}
    for order, kh, error in reference_slopes(fixed, points):
        (line,) = axes.plot(kh, error, color="grey", linestyle=(0, (2, 2)), linewidth=1, label=f"slope {order}")
        handles.append(line)
    set_log_scales(axes)
    axes.set_xlabel("k·h (step in units of 1/k = √(L/g))")
    axes.set_ylabel("reference error, max |r − r_ref| / A")
    axes.grid(True, which="major", alpha=0.3)
    axes.set_title(f"{scene}: convergence of the fixed-step integrators", pad=14)
    figure.legend(handles=handles + outcome_legend_handles()[:2], loc="outside right upper", fontsize=9)
    return figure


def tolerance(scene_frame: pd.DataFrame, stem: Path) -> Path:
    """``tolerance_figure`` saved under ``stem``."""
    return save(tolerance_figure(scene_frame), stem)


def tolerance_figure(scene_frame: pd.DataFrame) -> Figure:
    """Achieved reference error against the requested tolerance for the adaptive integrators of one scene,
    with the line error = tolerance."""
    scene = scene_frame["scene"].iloc[0]
    adaptive = scene_frame[scene_frame["tol"].notna()]
    figure = Figure(figsize=(9.5, 5.2), layout="constrained")
    axes = figure.subplots()
    handles = plot_sweeps(axes, adaptive, "tol", "reference_error")
    tol = adaptive["tol"].to_numpy(float)
    if tol.size:
        span = np.array([tol.min(), tol.max()])
        (line,) = axes.plot(span, span, color="grey", linestyle=(0, (2, 2)), linewidth=1, label="error = tolerance")
        handles.append(line)
    set_log_scales(axes)
    axes.invert_xaxis()
    axes.set_xlabel("requested tolerance (tighter to the right)")
    axes.set_ylabel("reference error, max |r − r_ref| / A")
    axes.grid(True, which="major", alpha=0.3)
    axes.set_title(f"{scene}: achieved error against requested tolerance", pad=14)
    figure.legend(handles=handles + outcome_legend_handles()[:2], loc="outside right upper", fontsize=9)
    return figure
