"""The report's interactive charts: plotly figures for index.html, drawn from the same data as ``reports.charts``.

Each function returns a ``plotly.graph_objects.Figure`` (plotly: https://plotly.com/python/); the document
embeds its JSON and plotly.js is written beside index.html (``PLOTLY_JS``), so the page opens offline. In every
chart of results rows, hovering a point shows the run (integrator, family, setting, error, CPU and wall time,
right-hand-side evaluations, steps, status); clicking a legend entry hides that integrator, clicking the
"all <family>" entry hides or shows the whole family (``LEGEND_SCRIPT``); axes are logarithmic. The charts of
curves (study tables, the seed section) are converted from their matplotlib figures (``from_matplotlib``). Colours,
markers and dashes follow ``reports.charts`` (colour = family, marker = integrator, solid = fixed step,
dashed = tolerance sweep). Diverged and failed runs are drawn above the data (▲, ✕) at their cost.
"""

from __future__ import annotations

import math
from typing import Any, cast

import numpy as np
import pandas as pd
import plotly.graph_objects as go
from matplotlib.colors import to_hex
from matplotlib.figure import Figure as MplFigure
from matplotlib.gridspec import SubplotSpec
from matplotlib.ticker import FixedFormatter
from plotly.subplots import make_subplots

from foucault_bench.bench.schema import setting_label
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_OK
from foucault_bench.reports import charts

PLOTLY_JS = "plotly.min.js"
"""File name of plotly.js in the report folder."""

SYMBOLS = {"o": "circle", "s": "square", "D": "diamond", "v": "triangle-down", "P": "cross", "*": "star",
           "h": "hexagon", "<": "triangle-left", ">": "triangle-right", "p": "pentagon", "^": "triangle-up",
           "X": "x"}
"""matplotlib marker (``charts.INTEGRATOR_MARKERS``) → plotly symbol."""


def _dash(linestyle: object) -> str:
    """plotly dash of a ``charts`` line style: solid family for fixed steps, dashed family for tolerances."""
    for styles, dashes in ((charts.FIXED_STEP_LINESTYLES, ("solid", "dashdot", "dot")),
                           (charts.ADAPTIVE_LINESTYLES, ("dash", "longdashdot", "longdash"))):
        if linestyle in styles:
            return dashes[styles.index(linestyle)]
    return "solid"


HOVER_FIELDS = ("integrator", "family", "setting", "error", "cpu_time_s", "wall_time_s", "nfev", "steps", "status",
                "message")
RUN_HOVER = ("<b>%{customdata[0]}</b> (%{customdata[1]}), %{customdata[2]}<br>error %{customdata[3]}<br>"
             "CPU time %{customdata[4]} s, wall time %{customdata[5]} s<br>nfev %{customdata[6]}, "
             "steps %{customdata[7]}<br>status %{customdata[8]} %{customdata[9]}<extra></extra>")


def _text(value: object) -> str:
    if isinstance(value, (float, np.floating)):
        return "–" if not math.isfinite(value) else f"{value:.3g}"
    if value is None or value is pd.NA:
        return "–"
    return str(value)


def _hover(rows: pd.DataFrame, error_column: str) -> list[list[str]]:
    """customdata rows (``HOVER_FIELDS``) of results rows."""
    data = []
    for row in rows.to_dict("records"):
        values = {**row, "setting": setting_label(row.get("kh"), row.get("tol")),
                  "error": abs(row[error_column]) if row.get(error_column) is not None else math.nan}
        data.append([_text(values.get(field, math.nan)) for field in HOVER_FIELDS])
    return data


def _legend_layout(figure: go.Figure, title: str) -> go.Figure:
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
    """One trace per integrator through its ok runs (``charts.sweeps``) and, above the data at ``top``, one per
    integrator for its diverged and failed runs."""
    families_seen: set[str] = set()
    for sweep in charts.sweeps(frame, x_column, y_column):
        style = charts.integrator_style(sweep.integrator, sweep.family, sweep.adaptive)
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
        failed = pd.concat([sweep.diverged, sweep.failed])
        known = failed[np.isfinite(failed[x_column].astype(float)) & (failed[x_column].astype(float) > 0)]
        if top is not None and not known.empty:
            symbols = ["triangle-up" if status == STATUS_DIVERGED else "x" for status in known["status"]]
            figure.add_trace(go.Scatter(
                x=known[x_column], y=np.full(len(known), top), mode="markers", name=f"{sweep.integrator} not ok",
                legendgroup=sweep.family, showlegend=False,
                marker={"symbol": symbols, "size": 9, "color": style["color"], "line": {"width": 1, "color": "black"}},
                customdata=_hover(known, y_column), hovertemplate=RUN_HOVER), row=row, col=col)


def _top(frame: pd.DataFrame, column: str) -> float | None:
    """A y above every plotted value (×10 the largest), where not-ok runs are drawn."""
    values = np.abs(frame.loc[frame["status"] == STATUS_OK, column].to_numpy(float))
    values = values[np.isfinite(values) & (values > 0)]
    return float(values.max() * 10.0) if values.size else 1.0


def work_precision(scene_frame: pd.DataFrame, verdict: str, front: pd.DataFrame) -> go.Figure:
    """``charts.work_precision`` for the page: verdict against time (with the Pareto envelope and the spread of
    the repeats) and against accepted steps."""
    scene = scene_frame["scene"].iloc[0]
    title, label = charts.VERDICT_LABELS[verdict]
    time_cost, steps = charts.cost_axes(scene_frame)
    figure = make_subplots(rows=1, cols=2, shared_yaxes=True, horizontal_spacing=0.04)
    top = _top(scene_frame, verdict)
    for col, cost in ((1, time_cost), (2, steps)):
        add_sweeps(figure, scene_frame, cost, verdict, col=col, legend=col == 1,
                   x_spread=charts.COST_SPREADS.get(cost), top=top)
        figure.update_xaxes(type="log", title_text=charts.COST_LABELS[cost], row=1, col=col)
    if not front.empty:
        figure.add_trace(go.Scatter(x=front[time_cost], y=front["error"], mode="lines", line_shape="hv",
                                    name="Pareto front", line={"color": "rgba(0,0,0,0.35)", "width": 4},
                                    hoverinfo="skip"), row=1, col=1)
    figure.update_yaxes(type="log")
    figure.update_yaxes(title_text=label, row=1, col=1)
    return _legend_layout(figure, f"{scene}: {title} against cost (lower left is better)")


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
    points = {sweep.integrator: sweep.points for sweep in charts.sweeps(fixed, "kh", "reference_error")}
    for order, kh, error in charts.reference_slopes(fixed, points):
        figure.add_trace(go.Scatter(x=kh, y=error, mode="lines", name=f"slope {order}",
                                    line={"color": "grey", "dash": "dot", "width": 1}, hoverinfo="name"))
    figure.update_xaxes(type="log", title_text="k·h (step in units of 1/k = √(L/g))")
    figure.update_yaxes(type="log", title_text="reference error, max |r − r_ref| / A")
    return _legend_layout(figure, f"{scene}: convergence of the fixed-step integrators")


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
    return _legend_layout(figure, f"{scene}: achieved error against requested tolerance")


# --------------------------------------------------------------------------------------------------------------
# line charts drawn with matplotlib elsewhere (the seed section)
# --------------------------------------------------------------------------------------------------------------
DASHES = {"-": "solid", "--": "dash", ":": "dot", "-.": "dashdot"}
"""matplotlib line style → plotly dash."""


def _ticks(axis) -> dict[str, Any]:
    """Tick labels a chart set by hand (``set_yticks(positions, labels)``), for plotly."""
    if isinstance(axis.get_major_formatter(), FixedFormatter):
        return {"tickvals": list(axis.get_majorticklocs()), "ticktext": [t.get_text() for t in axis.get_ticklabels()]}
    return {}


def from_matplotlib(figure: MplFigure) -> go.Figure:
    """A plotly figure with the data lines of a matplotlib figure (``Line2D`` in data coordinates: colour,
    style, markers, width, label; panel titles, axis labels, scales and hand-set tick labels). Used for the
    charts of curves (study tables, the seed section), where hovering shows the curve and its x, y. A line
    without a label is named after its panel and left out of the legend when a labelled line of the same colour
    in the panel stands for it; lines drawn in axes coordinates (edge markers, reference lines) are left out."""
    panels = [axes for axes in figure.axes if axes.get_subplotspec() is not None and axes.get_visible()]
    specs = {axes: cast(SubplotSpec, axes.get_subplotspec()) for axes in panels}  # not None: filtered above
    geometry = specs[panels[0]].get_geometry()[:2] if panels else (1, 1)
    plot = make_subplots(rows=geometry[0], cols=geometry[1], horizontal_spacing=0.08,
                         subplot_titles=[axes.get_title() for axes in panels])
    legend_names: set[str] = set()
    for axes in panels:
        spec = specs[axes]
        row, col = spec.rowspan.start + 1, spec.colspan.start + 1
        lines = [line for line in axes.get_lines() if line.get_transform() == axes.transData]
        labelled_colours = {to_hex(line.get_color()) for line in lines if not str(line.get_label()).startswith("_")}
        for line in lines:
            colour = to_hex(line.get_color())
            label = str(line.get_label())
            labelled = not label.startswith("_")
            linestyle = str(line.get_linestyle())
            name = label if labelled else axes.get_title() + (" (dashed)" if linestyle == "--" else "")
            shown = (labelled or colour not in labelled_colours) and name not in legend_names
            legend_names.add(name)
            mode = "lines" if line.get_marker() in (None, "None", "", " ") else "markers" \
                if linestyle in ("None", "", " ") else "lines+markers"
            plot.add_trace(go.Scatter(
                x=np.asarray(line.get_xdata(), dtype=float), y=np.asarray(line.get_ydata(), dtype=float), mode=mode,
                name=name, legendgroup=name, showlegend=shown,
                line={"color": colour, "dash": DASHES.get(linestyle, "solid"), "width": float(line.get_linewidth())},
                marker={"color": colour, "symbol": SYMBOLS.get(str(line.get_marker()), "circle"),
                        "size": max(4.0, float(line.get_markersize()))},
                hovertemplate=f"{name}<br>x %{{x:.4g}}<br>y %{{y:.4g}}<extra></extra>"), row=row, col=col)
        plot.update_xaxes(title_text=axes.get_xlabel(), type="log" if axes.get_xscale() == "log" else "linear",
                          row=row, col=col, **_ticks(axes.xaxis))
        plot.update_yaxes(title_text=axes.get_ylabel(), type="log" if axes.get_yscale() == "log" else "linear",
                          autorange="reversed" if axes.yaxis_inverted() else True, row=row, col=col,
                          **_ticks(axes.yaxis))
    return _legend_layout(plot, figure.get_suptitle())


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
