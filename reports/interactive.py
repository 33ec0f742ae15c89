"""The report's interactive charts: plotly figures for index.html, drawn from the same data as ``reports.charts``.

Each function returns a plotly figure (plotly: https://plotly.com/python/) as plain data
(``reports.plotly_figure.Plot``, built without plotly's per-property checking); the document embeds its JSON and plotly.js is written beside index.html (``PLOTLY_JS``), so the page opens offline. In every
chart of results rows, hovering a point shows the run (integrator, family, setting, error, CPU and wall time,
right-hand-side evaluations, steps, status); clicking a legend entry hides that integrator, clicking the
"all <family>" entry hides or shows the whole family (``LEGEND_SCRIPT``); axes are logarithmic. The charts of
curves (study tables, the seed section) are converted from their matplotlib figures (``reports.plotly_conversion.from_matplotlib``). Colours,
markers and dashes follow ``reports.charts`` (colour = family, marker = integrator, solid = fixed step,
dashed = tolerance sweep). Diverged and failed runs are drawn above the data (▲, ✕) at their cost, or left of
every other point when their cost is unknown (a run that stopped before it was timed).
"""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pandas as pd

from foucault_bench.bench.schema import STATUS_TIMEOUT, setting_label
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_FAILED, STATUS_OK
from foucault_bench.reports import chart_style, charts
from foucault_bench.reports.plotly_figure import Plot, Trace, data_array, scatter, subplots

PLOTLY_JS = "plotly.min.js"
"""File name of plotly.js in the report folder."""

SYMBOLS = {"o": "circle", "s": "square", "D": "diamond", "v": "triangle-down", "P": "cross", "*": "star",
           "h": "hexagon", "<": "triangle-left", ">": "triangle-right", "p": "pentagon", "^": "triangle-up",
           "X": "x"}
"""matplotlib marker (``chart_style.INTEGRATOR_MARKERS``) → plotly symbol."""


def _dash(linestyle: object) -> str:
    """plotly dash of a ``charts`` line style: solid family for fixed steps, dashed family for tolerances."""
    for styles, dashes in ((chart_style.FIXED_STEP_LINESTYLES, ("solid", "dashdot", "dot")),
                           (chart_style.ADAPTIVE_LINESTYLES, ("dash", "longdashdot", "longdash"))):
        if linestyle in styles:
            return dashes[styles.index(linestyle)]
    return "solid"


HOVER_FIELDS = ("integrator", "family", "setting", "error", "cpu_time_s", "wall_time_s", "nfev", "steps", "status",
                "message")
RUN_HOVER = ("<b>%{customdata[0]}</b> (%{customdata[1]}), %{customdata[2]}<br>error %{customdata[3]}<br>"
             "CPU time %{customdata[4]} s, wall time %{customdata[5]} s<br>nfev %{customdata[6]}, "
             "steps %{customdata[7]}<br>status %{customdata[8]} %{customdata[9]}<extra></extra>")


def _text(value: object) -> str:
    if value is None or value is pd.NA:
        return "–"
    if isinstance(value, (float, np.floating, int, np.integer)) and not isinstance(value, bool):
        return chart_style.number_text(float(value))
    return str(value)


def _texts(values: pd.Series) -> list[str]:
    """``_text`` of each value of a column (numbers converted once per column)."""
    if pd.api.types.is_numeric_dtype(values) and not pd.api.types.is_bool_dtype(values):
        return [chart_style.number_text(value) for value in values.to_numpy(dtype=float, na_value=math.nan)]
    return [_text(value) for value in values.tolist()]


def _hover(rows: pd.DataFrame, error_column: str) -> list[list[str]]:
    """customdata rows (``HOVER_FIELDS``) of results rows, built a column at a time."""
    missing = ["–"] * len(rows)
    kh = rows["kh"].tolist() if "kh" in rows else [None] * len(rows)
    tol = rows["tol"].tolist() if "tol" in rows else [None] * len(rows)
    error = (rows[error_column].abs() if error_column in rows else pd.Series(math.nan, index=rows.index))
    columns = {"setting": [setting_label(step, tolerance) for step, tolerance in zip(kh, tol, strict=True)],
               "error": _texts(error)}
    texts = [columns[field] if field in columns else _texts(rows[field]) if field in rows else missing
             for field in HOVER_FIELDS]
    return [list(row) for row in zip(*texts, strict=True)]


def legend_layout(figure: Plot, title: str) -> Plot:
    """The title, size, legend and margins of every chart of the page (the template: ``Plot.to_json``)."""
    figure.update_layout(title={"text": title}, height=520, legend={"groupclick": "toggleitem", "font": {"size": 11}},
                         margin={"l": 70, "r": 20, "t": 60, "b": 60}, hovermode="closest")
    figure.update_axes("x", exponentformat="power")
    figure.update_axes("y", exponentformat="power")
    return figure


def _family_entry(family: str, colour: str) -> Trace:
    """A legend entry without data; a click on it shows or hides every trace of the family (``LEGEND_SCRIPT``)."""
    return scatter(x=[None], y=[None], mode="markers", name=f"all {family}", legendgroup=family,
                   legendgrouptitle={"text": family}, marker={"color": colour, "symbol": "square", "size": 10},
                   meta="family-toggle", hoverinfo="skip")


SWEEP_COLUMNS = ("integrator", "family", "status", "kh", "tol", *HOVER_FIELDS)
"""The columns of results rows a chart of sweeps reads (with its x, y and bar columns)."""


def add_sweeps(figure: Plot, frame: pd.DataFrame, x_column: str, y_column: str, *, row: int = 1, col: int = 1,
               legend: bool = True, x_spread: str | None = None, top: float | None = None) -> None:
    """One trace per integrator through its ok runs (``chart_style.sweeps``) and, when ``top`` is given, as the static
    charts draw them on their edges: one per integrator for its diverged and failed runs above the data at
    ``top`` (▲, ✕; "<integrator> not ok") and one for its ok runs without a plottable value below the data
    (▽, ``_bottom``; "<integrator> no value"), each at its x, or left of every run's x when that is unknown
    (``_left``)."""
    shown = dict.fromkeys((*SWEEP_COLUMNS, x_column, y_column, *([x_spread] if x_spread else [])))
    # only the columns drawn or shown: a whole results row is slow to copy into each sweep
    frame = frame[[column for column in shown if column in frame]].reset_index(drop=True)  # index = position
    hover = _hover(frame, y_column)  # every row's, once: a sweep's are hover[label] for its rows' labels
    families_seen: set[str] = set()
    left, left_slots = _left(frame, x_column), {"not ok": 0, "no value": 0}
    bottom = _bottom(frame, y_column)
    for sweep in chart_style.sweeps(frame, x_column, y_column):
        style = chart_style.integrator_style(sweep.integrator, sweep.family, sweep.adaptive)
        if legend and sweep.family not in families_seen:
            figure.add_trace(_family_entry(sweep.family, style["color"]), row=row, col=col)
        families_seen.add(sweep.family)
        points = sweep.points
        line = scatter(
            x=data_array(points[x_column]), y=data_array(points[y_column]), mode="lines+markers", name=sweep.label,
            legendgroup=sweep.family, showlegend=legend,
            line={"color": style["color"], "dash": _dash(style["linestyle"]), "width": 1.5},
            marker={"symbol": SYMBOLS.get(style["marker"], "circle"), "size": 7, "color": style["color"]},
            customdata=[hover[label] for label in points.index], hovertemplate=RUN_HOVER)
        if x_spread is not None and x_spread in points and points[x_spread].notna().any():
            half = 0.5 * points[x_spread].to_numpy(float)
            line["error_x"] = {"type": "data", "symmetric": False, "array": data_array(half),
                               "arrayminus": data_array(np.minimum(half, 0.9 * points[x_column].to_numpy(float))),
                               "thickness": 1, "width": 2}
        figure.add_trace(line, row=row, col=col)
        if top is None:
            continue
        for edge_rows, edge_y, name in ((pd.concat([sweep.diverged, sweep.failed]), top, "not ok"),
                                        (sweep.no_value, bottom, "no value")):
            if edge_rows.empty:
                continue
            x = edge_rows[x_column].to_numpy(dtype=float, copy=True)
            unknown = ~(np.isfinite(x) & (x > 0))
            x[unknown] = left * LEFT_EDGE_STEP ** (left_slots[name] + np.arange(int(unknown.sum())))
            left_slots[name] += int(unknown.sum())
            symbols = [EDGE_SYMBOLS.get(status, "triangle-down") if name == "not ok" else "triangle-down"
                       for status in edge_rows["status"]]
            figure.add_trace(scatter(
                x=data_array(x), y=data_array(np.full(len(edge_rows), edge_y)), mode="markers",
                name=f"{sweep.integrator} {name}", legendgroup=sweep.family, showlegend=False,
                marker={"symbol": symbols, "size": 9, "color": style["color"], "line": {"width": 1, "color": "black"}},
                customdata=[hover[label] for label in edge_rows.index], hovertemplate=RUN_HOVER), row=row, col=col)


LEFT_EDGE_STEP = 0.8
"""Runs without a known x are drawn side by side leftwards from ``_left``, each this factor left of the last."""


def _left(frame: pd.DataFrame, column: str) -> float:
    """An x left of every run's finite positive x (half the smallest), where runs of unknown x are drawn."""
    values = frame[column].to_numpy(dtype=float)
    values = values[np.isfinite(values) & (values > 0)]
    return float(values.min() * 0.5) if values.size else 1.0


EDGE_SYMBOLS = {STATUS_DIVERGED: "triangle-up", STATUS_FAILED: "x", STATUS_TIMEOUT: "x"}
"""Run status → plotly symbol of its marker above the data (``chart_style.DIVERGED_MARKER``, ``FAILED_MARKER``)."""


def _bottom(frame: pd.DataFrame, column: str) -> float:
    """A y below every plotted value (÷10 the smallest), where ok runs without a plottable value are drawn."""
    values = np.abs(frame[column].to_numpy(float)[(frame["status"] == STATUS_OK).to_numpy(bool)])
    values = values[np.isfinite(values) & (values > 0)]
    return float(values.min() / 10.0) if values.size else 0.1


def _top(frame: pd.DataFrame, column: str) -> float | None:
    """A y above every plotted value (×10 the largest), where not-ok runs are drawn."""
    values = np.abs(frame[column].to_numpy(float)[(frame["status"] == STATUS_OK).to_numpy(bool)])
    values = values[np.isfinite(values) & (values > 0)]
    return float(values.max() * 10.0) if values.size else 1.0


AXIS_TITLE_CHARACTERS = 34
"""The longest line of a work-precision chart's axis title: two panels side by side, drawn beside a table too."""


def _wrapped(label: str) -> str:
    """An axis title broken into lines of at most ``AXIS_TITLE_CHARACTERS`` (plotly breaks at ``<br>`` only)."""
    return "<br>".join(textwrap.wrap(" ".join(label.split()), AXIS_TITLE_CHARACTERS))


def work_precision(scene_frame: pd.DataFrame, verdict: str, front: pd.DataFrame) -> Plot:
    """``charts.work_precision`` for the page: verdict against time (with the Pareto envelope and the 95 %
    confidence interval of each median CPU time) and against accepted steps."""
    scene = scene_frame["scene"].iloc[0]
    title, label = charts.VERDICT_LABELS[verdict]
    time_cost, steps = charts.cost_axes(scene_frame)
    scene_frame = charts.with_cost_bars(scene_frame)
    figure = subplots(rows=1, cols=2, shared_yaxes=True, horizontal_spacing=0.04)
    top = _top(scene_frame, verdict)
    for col, cost in ((1, time_cost), (2, steps)):
        add_sweeps(figure, scene_frame, cost, verdict, col=col, legend=col == 1,
                   x_spread=charts.COST_SPREADS.get(cost), top=top)
        figure.update_axes("x", type="log", title={"text": _wrapped(charts.COST_LABELS[cost])}, automargin=True,
                           row=1, col=col)
    if not front.empty:
        figure.add_trace(scatter(x=data_array(front[time_cost]), y=data_array(front["error"]), mode="lines",
                                 name="Pareto front", line={"color": "rgba(0,0,0,0.35)", "width": 4, "shape": "hv"},
                                 hoverinfo="skip"), row=1, col=1)
    figure.update_axes("y", type="log")
    figure.update_axes("y", title={"text": label}, row=1, col=1)
    return legend_layout(figure, f"{scene}: {title} against cost (lower left is better)")


def convergence(scene_frame: pd.DataFrame, orders: dict[str, float]) -> Plot:
    """``charts.convergence`` for the page: reference error against k·h with a reference slope per order."""
    scene = scene_frame["scene"].iloc[0]
    fixed = scene_frame[scene_frame["tol"].isna()]
    figure = subplots(rows=1, cols=1)
    add_sweeps(figure, fixed, "kh", "reference_error", top=_top(fixed, "reference_error"))
    for trace in figure.data:
        fitted = orders.get(str(trace["name"]).split(" (")[0])
        if fitted is not None and trace.get("meta") != "family-toggle" and trace.get("showlegend") is not False:
            trace["name"] = f"{trace['name']}, " + ("no fit" if not np.isfinite(fitted) else f"fitted order {fitted:.2f}")
    points = {sweep.integrator: sweep.points for sweep in chart_style.sweeps(fixed, "kh", "reference_error")}
    for order, kh, error in charts.reference_slopes(fixed, points):
        figure.add_trace(scatter(x=data_array(kh), y=data_array(error), mode="lines", name=f"slope {order}",
                                 line={"color": "grey", "dash": "dot", "width": 1}, hoverinfo="name"))
    figure.update_axes("x", type="log", title={"text": "k·h (step in units of 1/k = √(L/g))"})
    figure.update_axes("y", type="log", title={"text": "reference error, max |r − r_ref| / A"})
    return legend_layout(figure, f"{scene}: convergence of the fixed-step integrators")


def tolerance(scene_frame: pd.DataFrame) -> Plot:
    """``charts.tolerance`` for the page: achieved reference error against requested tolerance."""
    scene = scene_frame["scene"].iloc[0]
    adaptive = scene_frame[scene_frame["tol"].notna()]
    figure = subplots(rows=1, cols=1)
    add_sweeps(figure, adaptive, "tol", "reference_error", top=_top(adaptive, "reference_error"))
    tol = adaptive["tol"].to_numpy(float)
    if tol.size:
        span = [float(tol.min()), float(tol.max())]
        figure.add_trace(scatter(x=span, y=span, mode="lines", name="error = tolerance",
                                 line={"color": "grey", "dash": "dot", "width": 1}))
    figure.update_axes("x", type="log", autorange="reversed", title={"text": "requested tolerance (tighter to the right)"})
    figure.update_axes("y", type="log", title={"text": "reference error, max |r − r_ref| / A"})
    return legend_layout(figure, f"{scene}: achieved error against requested tolerance")




# --------------------------------------------------------------------------------------------------------------
# the page
# --------------------------------------------------------------------------------------------------------------
def drawn_points(figure: Plot) -> int:
    """How many markers plotly draws for ``figure``: points of marker traces with finite coordinates (and
    positive ones on log axes). The browser test compares this with the markers found on the page."""
    layout = figure.layout
    count = 0
    for trace in figure.data:
        if "markers" not in (trace.get("mode") or "") or trace.get("x") is None or trace.get("y") is None:
            continue
        x_axis = layout.get("xaxis" + str(trace.get("xaxis") or "x")[1:], {})
        y_axis = layout.get("yaxis" + str(trace.get("yaxis") or "y")[1:], {})
        trace_x, trace_y = list(trace["x"]), list(trace["y"])
        x = pd.to_numeric(pd.Series(trace_x), errors="coerce").to_numpy(float) \
            if x_axis.get("type") != "category" else np.zeros(len(trace_x))
        y = pd.to_numeric(pd.Series(trace_y), errors="coerce").to_numpy(float)
        if len(y) and np.all(np.isnan(y)) and isinstance(trace_y[0], str):
            y = np.zeros(len(trace_y))  # categorical y (the adequacy chart's labels)
        keep = np.isfinite(x) & np.isfinite(y)
        if x_axis.get("type") == "log":
            keep &= x > 0
        if y_axis.get("type") == "log":
            keep &= y > 0
        count += int(keep.sum())
    return count


LEGEND_SCRIPT = """
function foucaultLegendClick(chart, event) {
  var trace = event.data[event.curveNumber];
  if (trace.meta !== 'family-toggle') { return true; }
  var group = trace.legendgroup, members = [], visible = [];
  event.data.forEach(function (other, index) {
    if (other.legendgroup === group && other.meta !== 'family-toggle') { members.push(index); }
  });
  var hide = members.some(function (index) { return event.data[index].visible !== 'legendonly'; });
  members.forEach(function () { visible.push(hide ? 'legendonly' : true); });
  Plotly.restyle(chart, {visible: visible}, members);
  return false;
}
"""
"""Legend clicks: an "all <family>" entry hides (or shows) every trace of its family; other entries keep
plotly's default (hide that integrator; double click: show only it)."""
