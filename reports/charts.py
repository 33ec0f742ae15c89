"""The report's charts: each function reads plain DataFrames (results rows or study tables) and writes one
figure as PNG and SVG. Nothing here computes a result; ``bench.studies`` and ``reports.tables`` do.

Conventions shared by every chart:

* colour = integrator family (``family_colour``, the same in every chart and report), marker and line
  pattern = integrator within its family, solid-type lines = fixed-step sweeps (k·h), dashed-type lines =
  tolerance sweeps;
* runs that diverged, failed or timed out are never dropped: they are drawn as a marker on the top edge of the
  axes at their cost (▲ diverged, ✕ failed or timed out; at the left edge when the cost is unknown); an ok run
  without a finite, positive value is drawn on the bottom edge (▽); the interactive charts draw the same
  markers above and below their data;
* log axes wherever values span decades; axis labels carry units;
* work-precision charts: cost = CPU time where the results have it, else wall time
  (``bench.verdicts.pareto.cost_column``), its precision as horizontal bars (the 95 % confidence interval of
  the median CPU time; the spread of the repeats for wall time), the Pareto
  envelope as a grey staircase, each line's finest setting written at its end.

``reports.interactive`` draws the same charts for the HTML page from the same ``sweeps``; these are the static
PNG/SVG files for papers. Figures are built with ``matplotlib.figure.Figure`` (no pyplot state), so importing this module never changes
the backend an interactive session uses; saving renders with Agg.
"""

from __future__ import annotations

import colorsys
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd
from matplotlib import colors
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from foucault_bench.bench.schema import setting_label
from foucault_bench.bench.verdicts.pareto import cost_column
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_FAILED, STATUS_OK
from foucault_bench.integrators.registry import REGISTRY
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S

FAMILY_PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#bcbd22",
                  "#17becf")
"""The qualitative palette the families take in turn: matplotlib's ``tab10`` without its grey (grey is for
curves that are no integrator's, e.g. the Pareto envelope and the seed's analytic curves)."""
EXTENSION_LIGHTNESS = 0.42
EXTENSION_SATURATION = 0.75
"""Past the palette, families take evenly spaced hues at this HSL lightness and saturation."""
INTEGRATOR_MARKERS = ("o", "s", "D", "v", "P", "*", "h", "<", ">", "p")
FIXED_STEP_LINESTYLES = ("-", "-.", (0, (1, 1)))
"""Solid family: fixed-step sweeps; the second and third integrator of a family get dash-dot and dotted."""
ADAPTIVE_LINESTYLES = ("--", (0, (6, 2, 1, 2, 1, 2)), (0, (3, 3)))
"""Dashed family: tolerance sweeps."""
DIVERGED_MARKER = "^"
FAILED_MARKER = "X"
NO_VALUE_MARKER = "v"
LOG_FLOOR = 1e-17
"""Values below this (exact zeros included) are drawn at it on log axes; captions say so."""


# --------------------------------------------------------------------------------------------------------------
# styles
# --------------------------------------------------------------------------------------------------------------
def family_colours(families: Sequence[str]) -> dict[str, str]:
    """A distinct colour for each of ``families`` (distinct names), in their order: ``FAMILY_PALETTE`` first,
    then evenly spaced HSL hues (offset by half a step)."""
    extra = max(0, len(families) - len(FAMILY_PALETTE))
    extension = [colors.to_hex(colorsys.hls_to_rgb((index + 0.5) / extra, EXTENSION_LIGHTNESS,
                                                   EXTENSION_SATURATION)) for index in range(extra)]
    return dict(zip(families, (*FAMILY_PALETTE, *extension)[: len(families)], strict=True))


def family_colour(family: str) -> str:
    """The colour of ``family``: ``family_colours`` of the registered families in sorted order, so that no two
    registered families share one, plug-ins' included. A family no registered integrator has (rows of a
    removed plug-in) comes after them, so it shares no registered family's colour either."""
    registered = sorted({item.family for item in REGISTRY.values()})
    return family_colours(registered if family in registered else [*registered, family])[family]


def integrator_style(integrator: str, family: str, adaptive: bool | None = None) -> dict:
    """Colour (family), marker and line style (rank of the name within its family in the registry; solid
    family for fixed-step, dashed family for adaptive)."""
    registered = REGISTRY.get(integrator)
    if adaptive is None:
        adaptive = bool(registered.adaptive) if registered is not None else False
    siblings = sorted({name for name, item in REGISTRY.items() if item.family == family} | {integrator})
    rank = siblings.index(integrator)
    linestyles = ADAPTIVE_LINESTYLES if adaptive else FIXED_STEP_LINESTYLES
    return {
        "color": family_colour(family),
        "marker": INTEGRATOR_MARKERS[rank % len(INTEGRATOR_MARKERS)],
        "linestyle": linestyles[rank % len(linestyles)],
    }


def _ordered_integrators(frame: pd.DataFrame) -> list[tuple[str, str]]:
    """(integrator, family) pairs present in ``frame``, grouped by family, then by name."""
    pairs = frame[["integrator", "family"]].drop_duplicates()
    return sorted(((row.integrator, row.family) for row in pairs.itertuples()), key=lambda p: (p[1], p[0]))


def set_log_scales(axes: Axes, x: bool = True, y: bool = True) -> None:
    """Log scale on x and/or y. An axis without any finite positive data (every run failed, say) gets the
    placeholder limits 1 to 10 and the panel says so, instead of failing to draw."""
    empty = False
    for use, interval, set_scale, set_limits in ((x, axes.dataLim.intervalx, axes.set_xscale, axes.set_xlim),
                                                 (y, axes.dataLim.intervaly, axes.set_yscale, axes.set_ylim)):
        if not use:
            continue
        set_scale("log")
        low, high = interval
        if not (np.isfinite(low) and np.isfinite(high) and high > 0):
            set_limits(1.0, 10.0)
            empty = True
    if empty:
        axes.text(0.5, 0.5, "no finite positive values to plot", transform=axes.transAxes, ha="center",
                  color="grey")


def number_text(value: float) -> str:
    """A number for titles, legends and hover texts, with the 4 significant digits the tables print: whole
    numbers in full (3600, not 3.6e+03), others as ``%.4g`` (0.2726, 1e-08); "–" when not finite."""
    if not math.isfinite(value):
        return "–"
    if value == round(value) and abs(value) < 1e15:
        return str(int(round(value)))
    return f"{value:.4g}"


def save(figure: Figure, stem: Path) -> Path:
    """Write ``stem``.png (120 dpi) and ``stem``.svg; return the stem."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(stem.with_suffix(".png"), dpi=120)
    figure.savefig(stem.with_suffix(".svg"))
    return stem


# --------------------------------------------------------------------------------------------------------------
# edge markers for runs without a plottable value
# --------------------------------------------------------------------------------------------------------------
def mark_on_edge(axes: Axes, x_values: np.ndarray, colour: str, marker: str, edge: str,
                 first_left_slot: int = 0) -> int:
    """Markers on the top (``edge='top'``) or bottom edge of ``axes`` at data x, drawn outside the clip box so
    they stay visible. Markers whose x is not finite and positive go to the left edge, side by side from slot
    ``first_left_slot`` on; returns how many went there."""
    x = np.asarray(x_values, dtype=float)
    if x.size == 0:
        return 0
    y = 1.0 if edge == "top" else 0.0
    known = np.isfinite(x) & (x > 0)
    style: dict[str, Any] = {"marker": marker, "markersize": 9, "linestyle": "none", "markerfacecolor": colour,
             "markeredgecolor": "black", "clip_on": False, "zorder": 5}
    if known.any():
        axes.plot(x[known], np.full(known.sum(), y), transform=axes.get_xaxis_transform(), **style)
    unknown = int((~known).sum())
    if unknown:
        slots = 0.015 + 0.03 * (first_left_slot + np.arange(unknown))
        axes.plot(slots, np.full(unknown, y), transform=axes.transAxes, **style)
    return unknown


def outcome_legend_handles() -> list[Line2D]:
    """Legend entries explaining the edge markers."""
    common: dict[str, Any] = {"linestyle": "none", "markerfacecolor": "white", "markeredgecolor": "black",
                              "markersize": 8}
    return [
        Line2D([], [], marker=DIVERGED_MARKER, label="diverged (drawn on the top edge)", **common),
        Line2D([], [], marker=FAILED_MARKER, label="failed (drawn on the top edge)", **common),
        Line2D([], [], marker=NO_VALUE_MARKER, label="ok, no finite positive value (bottom edge)", **common),
    ]


@dataclass
class Sweep:
    """One integrator's runs in a chart of results rows, split by what can be drawn where.

    Attributes:
        integrator, family: identity; ``adaptive`` is true for a tolerance sweep.
        points: ok runs with a finite, positive x and y, ordered along the sweep (coarse to fine).
        no_value: ok runs without a plottable x or y (drawn on the bottom edge).
        diverged: runs that diverged; failed: runs that failed or timed out (drawn on the top edge at their x).
    """

    integrator: str
    family: str
    adaptive: bool
    points: pd.DataFrame
    no_value: pd.DataFrame
    diverged: pd.DataFrame
    failed: pd.DataFrame

    @property
    def label(self) -> str:
        """The integrator with its counts of diverged and failed runs."""
        statuses = pd.concat([self.diverged["status"], self.failed["status"]]).value_counts(sort=False)
        counts = [f"{count} {status}" for status, count in statuses.items()]
        return self.integrator + (f" ({', '.join(counts)})" if counts else "")


def sweeps(frame: pd.DataFrame, x_column: str, y_column: str) -> list[Sweep]:
    """The ``Sweep`` of every integrator in ``frame`` (grouped by family, then name) for a chart of
    ``y_column`` against ``x_column``; y is taken as |y|."""
    status = frame["status"].to_numpy(object)
    ok, diverged = status == STATUS_OK, status == STATUS_DIVERGED
    x = frame[x_column].to_numpy(dtype=float)
    y = np.abs(frame[y_column].to_numpy(dtype=float))
    plottable = np.isfinite(x) & (x > 0) & np.isfinite(y) & (y > 0)
    along = -frame["kh"].fillna(frame["tol"]).to_numpy(dtype=float)  # coarse to fine
    names, tolerance_sweep = frame["integrator"].to_numpy(object), frame["tol"].notna().to_numpy(bool)
    found = []
    for integrator, family in _ordered_integrators(frame):
        mine = names == integrator
        drawn = np.flatnonzero(mine & ok & plottable)
        drawn = drawn[np.argsort(along[drawn], kind="stable")]
        found.append(Sweep(integrator, family, bool(tolerance_sweep[mine].any()),
                           frame.iloc[drawn].assign(**{y_column: y[drawn]}),
                           frame.iloc[np.flatnonzero(mine & ok & ~plottable)],
                           frame.iloc[np.flatnonzero(mine & diverged)],
                           frame.iloc[np.flatnonzero(mine & ~ok & ~diverged)]))
    return found


def setting_text(row) -> str:
    """``kh=0.125`` or ``tol=1e-08`` for a results row."""
    return setting_label(row["kh"], row["tol"])


def plot_sweeps(axes: Axes, frame: pd.DataFrame, x_column: str, y_column: str, *, x_spread: str | None = None,
                labels: bool = True) -> list[Line2D]:
    """One line per integrator through its ok runs in sweep order (largest k·h or tolerance first); diverged and
    failed runs and ok runs without a plottable value as edge markers. ``x_spread`` names a column drawn as a
    horizontal bar of that total length centred on each point (the cost's precision, ``COST_SPREADS``); ``labels``
    writes the setting next to the last (finest) point of each line. Returns one legend handle per integrator,
    labelled with its counts of diverged and failed runs."""
    handles = []
    left_slots = {"top": 0, "bottom": 0}
    for sweep in sweeps(frame, x_column, y_column):
        style = integrator_style(sweep.integrator, sweep.family, sweep.adaptive)
        x = sweep.points[x_column].to_numpy(dtype=float)
        y = sweep.points[y_column].to_numpy(dtype=float)
        (line,) = axes.plot(x, y, label=sweep.label, markersize=5, **style)
        handles.append(line)
        if x_spread is not None and x_spread in sweep.points and sweep.points[x_spread].notna().any():
            half = 0.5 * sweep.points[x_spread].to_numpy(dtype=float)
            barred = np.isfinite(half)  # a run without a stated precision gets no bar
            axes.errorbar(x[barred], y[barred], xerr=np.vstack([np.minimum(half, 0.9 * x), half])[:, barred],
                          fmt="none", ecolor=style["color"], elinewidth=0.8, capsize=2, alpha=0.7)
        if labels and len(x):  # the finest setting, at the end of the line
            axes.annotate(setting_text(sweep.points.iloc[-1]), (x[-1], y[-1]), fontsize=6.5, color=style["color"],
                          xytext=(4, 3), textcoords="offset points")
        no_value = sweep.no_value[x_column].to_numpy(dtype=float)
        left_slots["bottom"] += mark_on_edge(axes, no_value, style["color"], NO_VALUE_MARKER, "bottom",
                                             left_slots["bottom"])
        for rows, marker in ((sweep.diverged, DIVERGED_MARKER), (sweep.failed, FAILED_MARKER)):
            left_slots["top"] += mark_on_edge(axes, rows[x_column].to_numpy(dtype=float), style["color"], marker,
                                              "top", left_slots["top"])
    return handles


def plot_front(axes: Axes, front: pd.DataFrame, cost: str) -> Line2D | None:
    """The Pareto envelope (``bench.verdicts.pareto.pareto_front``) as a staircase: each front run holds its
    error until a costlier run does better."""
    if front.empty:
        return None
    (line,) = axes.step(front[cost].to_numpy(float), front["error"].to_numpy(float), where="post", color="black",
                        linewidth=2.2, alpha=0.35, zorder=1, label="Pareto front (no run is cheaper and more accurate)")
    return line


# --------------------------------------------------------------------------------------------------------------
# charts of the results table
# --------------------------------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------------------------------
# charts of the study tables
# --------------------------------------------------------------------------------------------------------------
def long_time_energy(table: pd.DataFrame) -> Figure:
    """|E − E₀|/E_swing against time on log-log axes, one run of the long-time energy study per colour: the
    largest value so far (bold) over the values themselves (faint), so that bounded, drifting and growing
    errors read apart."""
    figure = Figure(figsize=(11, 5.6), layout="constrained")
    axes = figure.subplots()
    handles = []
    for integrator, family in _ordered_integrators(table):
        rows = table[table["integrator"] == integrator]
        style = integrator_style(integrator, family)
        status = rows["status"].iloc[0]
        t = rows["t_s"].to_numpy(dtype=float)
        error = np.abs(rows["energy_rel_error"].to_numpy(dtype=float))
        finite = np.isfinite(error)
        label = f"{integrator} ({rows['setting'].iloc[0]})" + ("" if status == STATUS_OK else f": {status}")
        shown = np.maximum(error[finite], LOG_FLOOR)
        axes.plot(t[finite], shown, color=style["color"], linestyle="-", linewidth=0.5, alpha=0.25)
        (line,) = axes.plot(t[finite], np.maximum.accumulate(shown) if shown.size else shown, label=label,
                            color=style["color"], linestyle=style["linestyle"], linewidth=1.8)
        handles.append(line)
        if status != STATUS_OK:
            last = t[finite][-1] if finite.any() else np.nan
            mark_on_edge(axes, np.array([last]), style["color"],
                         DIVERGED_MARKER if status == STATUS_DIVERGED else FAILED_MARKER, "top")
    set_log_scales(axes)
    axes.set_xlabel("time t (s)")
    axes.set_ylabel("relative energy error |E(t) − E₀| / E_swing")
    axes.grid(True, which="major", alpha=0.3)
    first = table.iloc[0]
    axes.set_title(f"Long-time energy: {first['config_model']} model, L = {first['config_length_m']:g} m, "
                   f"φ = {first['config_latitude_deg']:g}°, A = {first['config_amplitude_m']:g} m", pad=14)
    line_kinds = [Line2D([], [], color="grey", linewidth=1.8, label="thick: largest error so far"),
                  Line2D([], [], color="grey", linewidth=0.5, alpha=0.4, label="faint: error at each output time")]
    figure.legend(handles=handles + line_kinds + outcome_legend_handles()[:2], loc="outside right upper", fontsize=9)
    return figure


def stability(table: pd.DataFrame) -> Figure:
    """Max relative energy error over a long run against k·h, one panel per fixed-step integrator, without
    Earth's rotation (solid) and with it (dashed), with the declared limit (dashed line) and the measured one
    (triangle on the axis)."""
    integrators = _ordered_integrators(table)
    columns = 2
    rows_of_panels = (len(integrators) + columns - 1) // columns
    figure = Figure(figsize=(12, 3.6 * rows_of_panels + 0.8), layout="constrained")
    # y not shared: a panel whose runs all diverge (explicit Euler) would impose its placeholder limits on all
    panels = np.atleast_1d(figure.subplots(rows_of_panels, columns, sharex=True, squeeze=False)).ravel()
    for axes, (integrator, family) in zip(panels, integrators, strict=False):  # spare panels: hidden below
        style = integrator_style(integrator, family)
        for rotation, linestyle in ((False, "-"), (True, "--")):
            rows = table[(table["integrator"] == integrator) & (table["rotation"] == rotation)].sort_values("kh")
            if rows.empty:
                continue
            x = rows["kh"].to_numpy(dtype=float)
            y = rows["energy_max_rel_error"].to_numpy(dtype=float)
            statuses = rows["status"].to_numpy()
            ok = statuses == STATUS_OK
            axes.plot(x[ok], np.maximum(y[ok], LOG_FLOOR), color=style["color"], marker=style["marker"],
                      markersize=3.5, linestyle=linestyle, alpha=1.0 if rotation else 0.6)
            mark_on_edge(axes, x[statuses == STATUS_DIVERGED], style["color"], DIVERGED_MARKER, "top")
            mark_on_edge(axes, x[statuses == STATUS_FAILED], style["color"], FAILED_MARKER, "top")
            measured = float(rows["measured_limit_kh"].iloc[0])
            if np.isfinite(measured):
                axes.plot([measured], [0.0], marker="^" if rotation else "v", color="black", markersize=7,
                          transform=axes.get_xaxis_transform(), clip_on=False, linestyle="none")
        limit = float(table.loc[table["integrator"] == integrator, "stability_limit_kh"].iloc[0])
        if np.isfinite(limit):
            axes.axvline(limit, color="black", linestyle="--", linewidth=1)
            axes.axvspan(limit, max(table["kh"].max(), limit) * 1.02, color="#d62728", alpha=0.07)
            axes.text(limit, 0.06, f" declared limit kh = {limit:.4g}", transform=axes.get_xaxis_transform(),
                      fontsize=9)
        else:
            axes.text(0.02, 0.06, "no declared limit: unstable for every h > 0", transform=axes.transAxes,
                      fontsize=9)
        set_log_scales(axes, x=False)
        axes.set_title(integrator, pad=12)
        axes.grid(True, which="major", alpha=0.3)
    for axes in panels[len(integrators):]:
        axes.set_visible(False)
    for axes in panels[::columns]:
        axes.set_ylabel("max |E − E₀| / E_swing")
    for axes in panels[-columns:]:
        axes.set_xlabel("k·h (step in units of 1/k = √(L/g))")
    first = table.iloc[0]
    handles = [Line2D([], [], color="grey", linestyle="-", label="Ω_E = 0 (no rotation)"),
               Line2D([], [], color="grey", linestyle="--", label=f"Ω_E sidereal, φ = {first['config_latitude_deg']:g}°"),
               Line2D([], [], color="black", marker="v", linestyle="none", label="measured limit, no rotation"),
               Line2D([], [], color="black", marker="^", linestyle="none", label="measured limit, rotation")]
    figure.legend(handles=handles + outcome_legend_handles()[:2], loc="outside lower center", ncols=3, fontsize=9)
    figure.suptitle(f"Stability: {int(first['config_steps'])} steps of the {first['config_model']} model at each k·h, "
                    f"L = {first['config_length_m']:g} m")
    return figure


def rotation_growth(table: pd.DataFrame) -> Figure:
    """Per-step growth of the one-step map with Earth's rotation against k·h for the integrators that declare a
    growth law (unstable at every h once the frame rotates), measured (markers) against the law (line)."""
    figure = Figure(figsize=(7.5, 4.8), layout="constrained")
    axes = figure.subplots()
    rotating = table[table["rotation"] & np.isfinite(table["growth_theory"].to_numpy(dtype=float))]
    for (integrator, family), rows in rotating.groupby(["integrator", "family"], sort=True):
        rows = rows.sort_values("kh")
        style = integrator_style(integrator, family)
        axes.plot(rows["kh"], rows["growth_theory"], color=style["color"], linestyle="-", linewidth=1.2,
                  label=f"{integrator}: ½(kh)²(a/k)/√(1 − (kh/2)²)")
        axes.plot(rows["kh"], rows["growth_per_step"], color=style["color"], marker=style["marker"],
                  linestyle="none", markersize=5, label=f"{integrator}: measured max |λ| − 1")
    set_log_scales(axes, x=False)
    axes.set_xlabel("k·h")
    axes.set_ylabel("amplitude growth per step")
    if not rotating.empty:
        axes.set_title(f"Growth with Earth's rotation (a/k = {number_text(rotating['rate_ratio'].iloc[0])})", pad=10)
        axes.legend(fontsize=9)
    axes.grid(True, which="major", alpha=0.3)
    return figure


def precession_latitude(table: pd.DataFrame) -> Figure:
    """Measured precession rate against latitude next to −Ω_E sin φ, and the residual in units of Ω_E with
    the Airy correction."""
    rows = table.sort_values("latitude_deg")
    degrees_per_hour = np.degrees(1.0) * 3600.0
    latitude = rows["latitude_deg"].to_numpy(dtype=float)
    figure = Figure(figsize=(10, 8), layout="constrained")
    top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    top.plot(latitude, rows["textbook_rate_rad_s"] * degrees_per_hour, color="black", linewidth=1,
             label="textbook −Ω_E sin φ")
    top.plot(latitude, rows["rate_rad_s"] * degrees_per_hour, "o", color=family_colour("taylor"), markersize=5,
             label="measured (heyoka Taylor batch, turning points)")
    top.set_ylabel("precession rate (°/h, counter-clockwise positive)")
    top.axhline(0.0, color="grey", linewidth=0.6)
    top.legend(fontsize=9)
    top.grid(True, alpha=0.3)
    residual = (rows["rate_rad_s"] - rows["textbook_rate_rad_s"]) / SIDEREAL_EARTH_RATE_RAD_S
    airy = (rows["airy_rate_rad_s"] - rows["textbook_rate_rad_s"]) / SIDEREAL_EARTH_RATE_RAD_S
    bottom.errorbar(latitude, residual, yerr=rows["rate_stderr_rad_s"] / SIDEREAL_EARTH_RATE_RAD_S, fmt="o",
                    color=family_colour("taylor"), markersize=4, label="measured − textbook (±1 standard error)")
    bottom.plot(latitude, airy, "--", color="black", linewidth=1, label="Airy: (3/8)θ₀² Ω_E sin φ")
    bottom.axhline(0.0, color="grey", linewidth=0.6)
    bottom.set_xlabel("latitude φ (°, north positive)")
    bottom.set_ylabel("(rate − (−Ω_E sin φ)) / Ω_E")
    bottom.legend(fontsize=9)
    bottom.grid(True, alpha=0.3)
    first = rows.iloc[0]
    figure.suptitle(f"Precession against latitude: {first['config_model']} model, L = {first['config_length_m']:g} m, "
                    f"A = {first['config_amplitude_m']:g} m, {first['config_duration_s'] / 3600:g} h per latitude")
    return figure


def release_azimuth(table: pd.DataFrame) -> Figure:
    """Precession-rate error (relative to Ω_E) against the release azimuth, one panel per latitude, one line per
    integrator (log scale)."""
    latitudes = sorted(table["latitude_deg"].unique(), reverse=True)
    figure = Figure(figsize=(12, 4.6), layout="constrained")
    panels = np.atleast_1d(figure.subplots(1, len(latitudes), sharey=True, squeeze=False)).ravel()
    handles = {}
    for axes, latitude in zip(panels, latitudes, strict=True):
        rows = table[table["latitude_deg"] == latitude]
        for (integrator, family), sweep in rows.groupby(["integrator", "family"], sort=True):
            sweep = sweep.sort_values("release_azimuth_deg")
            style = integrator_style(integrator, family)
            ok = (sweep["status"] == STATUS_OK).to_numpy()
            (line,) = axes.plot(sweep["release_azimuth_deg"].to_numpy()[ok],
                                np.maximum(sweep["error_earth"].to_numpy(dtype=float)[ok], LOG_FLOOR),
                                color=style["color"], marker=style["marker"], markersize=4, label=integrator)
            handles[integrator] = line
        set_log_scales(axes, x=False)
        axes.set_xticks(np.arange(0, 181, 45))
        axes.set_xlabel("release azimuth (° from South towards East)")
        axes.set_title(f"φ = {latitude:g}°", pad=10)
        axes.grid(True, which="major", alpha=0.3)
    panels[0].set_ylabel("|rate − reference rate| / Ω_E")
    figure.legend(handles=list(handles.values()), loc="outside right upper", fontsize=9)
    first = table.iloc[0]
    figure.suptitle(f"Precession error against release direction (0° = North-South swing, 90° = East-West): "
                    f"{first['config_model']} model, L = {first['config_length_m']:g} m, "
                    f"A = {first['config_amplitude_m']:g} m, kh = {number_text(first['kh'])}, "
                    f"{number_text(first['config_duration_s'])} s")
    return figure


def adequacy(table: pd.DataFrame) -> Figure:
    """Per scene, what each simpler model gets wrong against the richer one (``bench.verdicts.adequacy``): |precession
    rate difference| in units of Ω_E|sin φ| and trajectory gap in units of A, measured (filled) next to the
    leading-order expectation (hollow) where the physics gives one; dot plot on log axes."""
    rows = table.reset_index(drop=True)
    labels = [f"{r.scene}: {r.simpler_model} vs {r.model}" for r in rows.itertuples()]
    figure = Figure(figsize=(13, 0.42 * len(rows) + 2.0), layout="constrained")
    panels = figure.subplots(1, 2, sharey=True)
    positions = np.arange(len(rows))
    panel_columns = (
        ("precession_rate_diff", "expected_rate_diff", "|rate(simpler) − rate(richer)| / (Ω_E |sin φ|)",
         "Precession rate missed"),
        ("trajectory_gap", "expected_trajectory_gap", "max |r(simpler) − r(richer)| / A", "Path missed"),
    )
    for axes, (measured_column, expected_column, label, title) in zip(panels, panel_columns, strict=True):
        axes.set_title(title, fontsize=10)
        measured = np.abs(rows[measured_column].to_numpy(dtype=float))
        shown = np.isfinite(measured) & (measured > 0)
        axes.plot(measured[shown], positions[shown], "o", color="#4c72b0", markersize=7, label="measured")
        values = [measured[shown]]
        if expected_column in rows:
            expected = np.abs(rows[expected_column].to_numpy(dtype=float))
            known = np.isfinite(expected) & (expected > 0)
            axes.plot(expected[known], positions[known], "o", markerfacecolor="none", markeredgecolor="black",
                      markersize=10, label="leading-order expectation", zorder=1.5)  # beneath the measured dots
            values.append(expected[known])
        for position in positions[~shown]:
            axes.text(0.01, position, "no finite value", transform=axes.get_yaxis_transform(), va="center",
                      fontsize=8)
        set_log_scales(axes, y=False)
        finite = np.concatenate(values)
        if finite.size:
            centre = np.sqrt(finite.min() * finite.max())
            half_span = max(10.0, np.sqrt(finite.max() / finite.min()) * 3.0)
            axes.set_xlim(centre / half_span, centre * half_span)
        axes.set_xlabel(label)
        axes.grid(True, axis="x", alpha=0.3)
    figure.legend(handles=panels[0].get_lines(), loc="outside lower center", ncols=2, fontsize=9)
    panels[0].set_yticks(positions, labels, fontsize=9)
    panels[0].set_ylim(len(rows) - 0.5, -0.5)
    figure.suptitle("Model adequacy: what each simpler model gets wrong, per scene")
    return figure
