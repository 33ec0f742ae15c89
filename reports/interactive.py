"""The report's interactive charts: plotly figures for index.html, drawn from the same data as ``reports.charts``.

Each function returns a ``plotly.graph_objects.Figure`` (plotly: https://plotly.com/python/); the document
embeds its JSON and plotly.js is written beside index.html (``PLOTLY_JS``), so the page opens offline. In every
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
import plotly.graph_objects as go
from plotly.subplots import make_subplots

from foucault_bench.bench.schema import STATUS_TIMEOUT, setting_label
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_FAILED, STATUS_OK
from foucault_bench.reports import chart_style, charts

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


def _hover(rows: pd.DataFrame, error_column: str) -> list[list[str]]:
    """customdata rows (``HOVER_FIELDS``) of results rows."""
    data = []
    needed = [column for column in dict.fromkeys((*HOVER_FIELDS, "kh", "tol", error_column)) if column in rows]
    for row in rows[needed].to_dict("records"):  # only the shown columns: a whole results row is slow to convert
        values = {**row, "setting": setting_label(row.get("kh"), row.get("tol")),
                  "error": abs(row[error_column]) if row.get(error_column) is not None else math.nan}
        data.append([_text(values.get(field, math.nan)) for field in HOVER_FIELDS])
    return data


def legend_layout(figure: go.Figure, title: str) -> go.Figure:
    figure.update_layout(title=title, template="plotly_white", height=520,
                         legend={"groupclick": "toggleitem", "font": {"size": 11}},
                         margin={"l": 70, "r": 20, "t": 60, "b": 60}, hovermode="closest")
    figure.update_xaxes(exponentformat="power")
    figure.update_yaxes(exponentformat="power")
    return figure


def _family_entry(family: str, colour: str) -> go.Scatter:
    """A legend entry without data; a click on it shows or hides every trace of the family (``LEGEND_SCRIPT``)."""
    return go.Scatter(x=[None], y=[None], mode="markers", name=f"all {family}", legendgroup=family,
                      legendgrouptitle_text=family, marker={"color": colour, "symbol": "square", "size": 10},
                      meta="family-toggle", hoverinfo="skip")


def add_sweeps(figure: go.Figure, frame: pd.DataFrame, x_column: str, y_column: str, *, row: int = 1, col: int = 1,
               legend: bool = True, x_spread: str | None = None, top: float | None = None) -> None:
    """One trace per integrator through its ok runs (``chart_style.sweeps``) and, when ``top`` is given, as the static
    charts draw them on their edges: one per integrator for its diverged and failed runs above the data at
    ``top`` (▲, ✕; "<integrator> not ok") and one for its ok runs without a plottable value below the data
    (▽, ``_bottom``; "<integrator> no value"), each at its x, or left of every run's x when that is unknown
    (``_left``)."""
    families_seen: set[str] = set()
    left, left_slots = _left(frame, x_column), {"not ok": 0, "no value": 0}
    bottom = _bottom(frame, y_column)
    for sweep in chart_style.sweeps(frame, x_column, y_column):
        style = chart_style.integrator_style(sweep.integrator, sweep.family, sweep.adaptive)
        if legend and sweep.family not in families_seen:
            figure.add_trace(_family_entry(sweep.family, style["color"]), row=row, col=col)
        families_seen.add(sweep.family)
        points = sweep.points
        error_x = None
        if x_spread is not None and x_spread in points and points[x_spread].notna().any():
            half = 0.5 * points[x_spread].to_numpy(float)
            error_x = {"type": "data", "symmetric": False, "array": half,
                       "arrayminus": np.minimum(half, 0.9 * points[x_column].to_numpy(float)), "thickness": 1,
                       "width": 2}
        figure.add_trace(go.Scatter(
            x=points[x_column], y=points[y_column], mode="lines+markers", name=sweep.label,
            legendgroup=sweep.family, showlegend=legend, error_x=error_x,
            line={"color": style["color"], "dash": _dash(style["linestyle"]), "width": 1.5},
            marker={"symbol": SYMBOLS.get(style["marker"], "circle"), "size": 7, "color": style["color"]},
            customdata=_hover(points, y_column), hovertemplate=RUN_HOVER), row=row, col=col)
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
            figure.add_trace(go.Scatter(
                x=x, y=np.full(len(edge_rows), edge_y), mode="markers", name=f"{sweep.integrator} {name}",
                legendgroup=sweep.family, showlegend=False,
                marker={"symbol": symbols, "size": 9, "color": style["color"], "line": {"width": 1, "color": "black"}},
                customdata=_hover(edge_rows, y_column), hovertemplate=RUN_HOVER), row=row, col=col)


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


def work_precision(scene_frame: pd.DataFrame, verdict: str, front: pd.DataFrame) -> go.Figure:
    """``charts.work_precision`` for the page: verdict against time (with the Pareto envelope and the 95 %
    confidence interval of each median CPU time) and against accepted steps."""
    scene = scene_frame["scene"].iloc[0]
    title, label = charts.VERDICT_LABELS[verdict]
    time_cost, steps = charts.cost_axes(scene_frame)
    scene_frame = charts.with_cost_bars(scene_frame)
    figure = make_subplots(rows=1, cols=2, shared_yaxes=True, horizontal_spacing=0.04)
    top = _top(scene_frame, verdict)
    for col, cost in ((1, time_cost), (2, steps)):
        add_sweeps(figure, scene_frame, cost, verdict, col=col, legend=col == 1,
                   x_spread=charts.COST_SPREADS.get(cost), top=top)
        figure.update_xaxes(type="log", title_text=_wrapped(charts.COST_LABELS[cost]), automargin=True, row=1, col=col)
    if not front.empty:
        figure.add_trace(go.Scatter(x=front[time_cost], y=front["error"], mode="lines", line_shape="hv",
                                    name="Pareto front", line={"color": "rgba(0,0,0,0.35)", "width": 4},
                                    hoverinfo="skip"), row=1, col=1)
    figure.update_yaxes(type="log")
    figure.update_yaxes(title_text=label, row=1, col=1)
    return legend_layout(figure, f"{scene}: {title} against cost (lower left is better)")


def convergence(scene_frame: pd.DataFrame, orders: dict[str, float]) -> go.Figure:
    """``charts.convergence`` for the page: reference error against k·h with a reference slope per order."""
    scene = scene_frame["scene"].iloc[0]
    fixed = scene_frame[scene_frame["tol"].isna()]
    figure = make_subplots(rows=1, cols=1)
    add_sweeps(figure, fixed, "kh", "reference_error", top=_top(fixed, "reference_error"))
    for trace in figure.data:
        fitted = orders.get(str(trace.name).split(" (")[0])
        if fitted is not None and trace.meta != "family-toggle" and trace.showlegend is not False:
            trace.name = f"{trace.name}, " + ("no fit" if not np.isfinite(fitted) else f"fitted order {fitted:.2f}")
    points = {sweep.integrator: sweep.points for sweep in chart_style.sweeps(fixed, "kh", "reference_error")}
    for order, kh, error in charts.reference_slopes(fixed, points):
        figure.add_trace(go.Scatter(x=kh, y=error, mode="lines", name=f"slope {order}",
                                    line={"color": "grey", "dash": "dot", "width": 1}, hoverinfo="name"))
    figure.update_xaxes(type="log", title_text="k·h (step in units of 1/k = √(L/g))")
    figure.update_yaxes(type="log", title_text="reference error, max |r − r_ref| / A")
    return legend_layout(figure, f"{scene}: convergence of the fixed-step integrators")


def tolerance(scene_frame: pd.DataFrame) -> go.Figure:
    """``charts.tolerance`` for the page: achieved reference error against requested tolerance."""
    scene = scene_frame["scene"].iloc[0]
    adaptive = scene_frame[scene_frame["tol"].notna()]
    figure = make_subplots(rows=1, cols=1)
    add_sweeps(figure, adaptive, "tol", "reference_error", top=_top(adaptive, "reference_error"))
    tol = adaptive["tol"].to_numpy(float)
    if tol.size:
        figure.add_trace(go.Scatter(x=[tol.min(), tol.max()], y=[tol.min(), tol.max()], mode="lines",
                                    name="error = tolerance", line={"color": "grey", "dash": "dot", "width": 1}))
    figure.update_xaxes(type="log", autorange="reversed", title_text="requested tolerance (tighter to the right)")
    figure.update_yaxes(type="log", title_text="reference error, max |r − r_ref| / A")
    return legend_layout(figure, f"{scene}: achieved error against requested tolerance")




# --------------------------------------------------------------------------------------------------------------
# the page
# --------------------------------------------------------------------------------------------------------------
def drawn_points(figure: go.Figure) -> int:
    """How many markers plotly draws for ``figure``: points of marker traces with finite coordinates (and
    positive ones on log axes). The browser test compares this with the markers found on the page."""
    layout = figure.layout
    count = 0
    for trace in figure.data:
        if "markers" not in (trace.mode or "") or trace.x is None or trace.y is None:
            continue
        x_axis = layout[("xaxis" + str(trace.xaxis or "x")[1:])]
        y_axis = layout[("yaxis" + str(trace.yaxis or "y")[1:])]
        x = pd.to_numeric(pd.Series(list(trace.x)), errors="coerce").to_numpy(float) \
            if x_axis.type != "category" else np.zeros(len(trace.x))
        y = pd.to_numeric(pd.Series(list(trace.y)), errors="coerce").to_numpy(float)
        if len(y) and np.all(np.isnan(y)) and len(trace.y) and isinstance(list(trace.y)[0], str):
            y = np.zeros(len(trace.y))  # categorical y (the adequacy chart's labels)
        keep = np.isfinite(x) & np.isfinite(y)
        if x_axis.type == "log":
            keep &= x > 0
        if y_axis.type == "log":
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
