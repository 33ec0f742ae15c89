"""The report's interactive charts: plotly figures for index.html, drawn from the same data as ``reports.charts``.

Each function returns a ``plotly.graph_objects.Figure`` (plotly: https://plotly.com/python/); the document
embeds its JSON and plotly.js is written beside index.html (``PLOTLY_JS``), so the page opens offline. In every
chart of results rows, hovering a point shows the run (integrator, family, setting, error, CPU and wall time,
right-hand-side evaluations, steps, status); clicking a legend entry hides that integrator, clicking the
"all <family>" entry hides or shows the whole family (``LEGEND_SCRIPT``); axes are logarithmic. The charts of
curves (study tables, the seed section) are converted from their matplotlib figures (``from_matplotlib``). Colours,
markers and dashes follow ``reports.charts`` (colour = family, marker = integrator, solid = fixed step,
dashed = tolerance sweep). Diverged and failed runs are drawn above the data (▲, ✕) at their cost, or left of
every other point when their cost is unknown (a run that stopped before it was timed).
"""

from __future__ import annotations

import math
import textwrap
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
import pandas as pd
import plotly.graph_objects as go
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_hex
from matplotlib.container import ErrorbarContainer
from matplotlib.figure import Figure as MplFigure
from matplotlib.ticker import FixedLocator
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
    points = {sweep.integrator: sweep.points for sweep in chart_style.sweeps(fixed, "kh", "reference_error")}
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
# charts of curves drawn with matplotlib (the study tables, the seed section)
# --------------------------------------------------------------------------------------------------------------
DASHES = {"-": "solid", "--": "dash", ":": "dot", "-.": "dashdot"}
"""matplotlib line style → plotly dash."""
PANEL_HEIGHT_PX = 300
"""Height of one row of panels of a converted figure (a single row gets the page's 520 px)."""


def _ticks(axis) -> dict[str, Any]:
    """Ticks a chart placed by hand (``set_xticks(positions)``, ``set_yticks(positions, labels)``: a
    ``FixedLocator``) with the labels its formatter writes (the ``FuncFormatter`` that ``set_ticklabels``
    installs, a ``FixedFormatter``, or the default one), for plotly."""
    if not isinstance(axis.get_major_locator(), FixedLocator):
        return {}
    positions = [float(value) for value in axis.get_majorticklocs()]
    labels = axis.get_major_formatter().format_ticks(positions)
    return {"tickvals": positions, "ticktext": [str(text) for text in labels]}


def _data_coordinates(axes, transform, xy: ArrayLike) -> np.ndarray:
    """Points given in ``transform``'s coordinates (data, axes fraction or a blend of both) in data
    coordinates, at the axes' current limits: a marker on an edge lands on that edge's value."""
    axes.get_xlim(), axes.get_ylim()  # applies pending autoscaling
    return (transform - axes.transData).transform(np.asarray(xy, dtype=float).reshape(-1, 2))


def _axes_fractions(axes, transform, xy: ArrayLike) -> np.ndarray:
    return (transform - axes.transAxes).transform(np.asarray(xy, dtype=float).reshape(-1, 2))


def _reference_line(axes, line) -> tuple[str, float] | None:
    """("v", x) for an ``axvline``, ("h", y) for an ``axhline`` (lines spanning the axes), else None."""
    x, y = np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)
    if line.get_transform() == axes.get_xaxis_transform() and list(y) == [0.0, 1.0] and len(set(x)) == 1:
        return "v", float(x[0])
    if line.get_transform() == axes.get_yaxis_transform() and list(x) == [0.0, 1.0] and len(set(y)) == 1:
        return "h", float(y[0])
    return None


def _marker(line) -> dict[str, Any]:
    """plotly marker of a matplotlib line: symbol (``-open`` for a hollow marker, coloured by its edge), size."""
    hollow = str(line.get_markerfacecolor()).lower() == "none"
    colour = to_hex(line.get_markeredgecolor() if hollow else line.get_markerfacecolor())
    symbol = SYMBOLS.get(line.get_marker(), "circle") + ("-open" if hollow else "")
    return {"color": colour, "symbol": symbol, "size": max(4.0, float(line.get_markersize())),
            "line": {"color": to_hex(line.get_markeredgecolor()), "width": 1}}


def _error_arrays(container, x: np.ndarray, y: np.ndarray) -> dict[str, Any]:
    """``error_x``/``error_y`` of an ``ErrorbarContainer``'s bars (segments) at points (x, y)."""
    errors: dict[str, Any] = {}
    for collection in container.lines[2]:
        segments = [np.asarray(segment, dtype=float) for segment in collection.get_segments()]
        if len(segments) != len(x):
            continue
        vertical = all(np.isclose(segment[0, 0], segment[-1, 0]) for segment in segments)
        index, centre = (1, y) if vertical else (0, x)
        low = np.array([segment[:, index].min() for segment in segments])
        high = np.array([segment[:, index].max() for segment in segments])
        errors["error_y" if vertical else "error_x"] = {
            "type": "data", "symmetric": False, "array": high - centre, "arrayminus": centre - low,
            "color": to_hex(collection.get_colors()[0]), "thickness": 1, "width": 3}
    return errors


def _line_trace(axes, line, errors: dict[str, Any], legend_names: set[str], labelled_colours: set[str]) -> go.Scatter:
    """A plotly trace of a matplotlib line (in data coordinates whatever transform it was drawn in)."""
    xy = _data_coordinates(axes, line.get_transform(), line.get_xydata())
    colour = to_hex(line.get_color())
    label = str(line.get_label())
    labelled = not label.startswith("_")
    linestyle = line.get_linestyle()
    name = label if labelled else axes.get_title() + (" (dashed)" if linestyle == "--" else "")
    shown = (labelled or colour not in labelled_colours) and name not in legend_names
    legend_names.add(name)
    has_marker = line.get_marker() not in (None, "None", "", " ")
    has_line = linestyle not in ("None", "", " ")
    mode = "+".join(part for part, present in (("lines", has_line), ("markers", has_marker)) if present) or "markers"
    return go.Scatter(
        x=xy[:, 0], y=xy[:, 1], mode=mode, name=name, legendgroup=name, showlegend=shown,
        line={"color": colour, "dash": DASHES.get(linestyle, "solid"), "width": float(line.get_linewidth())},
        marker=_marker(line), opacity=line.get_alpha() if line.get_alpha() is not None else 1.0,
        hovertemplate=f"{name}<br>x %{{x:.4g}}<br>y %{{y:.4g}}<extra></extra>", **errors)


def _add_patches(plot: go.Figure, axes, row: int, col: int) -> None:
    """Shaded spans (``axvspan``/``axhspan``: rectangles across the axes) as plotly rectangles, other patches
    and filled areas (``fill_between``) as filled traces in data coordinates."""
    for patch in axes.patches:
        path = patch.get_path().vertices
        fractions = _axes_fractions(axes, patch.get_transform(), path)
        data = _data_coordinates(axes, patch.get_transform(), path)
        face = patch.get_facecolor()
        style = {"fillcolor": to_hex(face), "opacity": float(face[3]), "line_width": 0, "layer": "below"}
        if np.allclose(sorted({round(v, 9) for v in fractions[:, 1]}), [0.0, 1.0]):
            plot.add_vrect(x0=float(data[:, 0].min()), x1=float(data[:, 0].max()), row=row, col=col, **style)
        elif np.allclose(sorted({round(v, 9) for v in fractions[:, 0]}), [0.0, 1.0]):
            plot.add_hrect(y0=float(data[:, 1].min()), y1=float(data[:, 1].max()), row=row, col=col, **style)
        else:
            plot.add_trace(go.Scatter(x=data[:, 0], y=data[:, 1], fill="toself", mode="lines", showlegend=False,
                                      fillcolor=to_hex(face, keep_alpha=True), line={"width": 0},
                                      name=str(patch.get_label()), hoverinfo="skip"), row=row, col=col)
    for collection in axes.collections:
        if not isinstance(collection, PolyCollection):
            continue
        faces: Any = collection.get_facecolor()  # an N×4 RGBA array (typed as one colour)
        for path in collection.get_paths():
            data = _data_coordinates(axes, collection.get_transform(), path.vertices)
            plot.add_trace(go.Scatter(x=data[:, 0], y=data[:, 1], fill="toself", mode="lines", showlegend=False,
                                      fillcolor=to_hex(faces[0], keep_alpha=True),
                                      line={"width": 0}, name=str(collection.get_label()), hoverinfo="skip"),
                          row=row, col=col)


def _add_texts(plot: go.Figure, axes, x_ref: str, y_ref: str) -> None:
    """Texts written on a panel, at the same place relative to its axes."""
    for text in axes.texts:
        if not text.get_visible() or not text.get_text().strip():
            continue
        position = _axes_fractions(axes, text.get_transform(), np.array(text.get_position()))[0]
        plot.add_annotation(x=float(position[0]), y=float(position[1]), xref=f"{x_ref} domain",
                            yref=f"{y_ref} domain", text=text.get_text().strip(), showarrow=False,
                            xanchor={"center": "center", "right": "right"}.get(text.get_horizontalalignment(), "left"),
                            font={"size": 10, "color": to_hex(text.get_color())})


def from_matplotlib(figure: MplFigure) -> go.Figure:
    """A plotly figure with what a matplotlib figure draws in its panels, each in its own panel: the lines
    (colour, style, markers, hollow markers as open symbols, width, label) whatever coordinates they were drawn
    in (a marker on an axes edge stays on that edge, in data coordinates), reference lines (``axhline``,
    ``axvline``) and shaded spans as plotly shapes, filled areas, error bars, texts, panel titles, axis labels,
    scales and hand-placed ticks and tick labels. Lines are drawn in matplotlib's z-order. Used for the charts
    of curves (study tables, the seed section), where hovering shows the curve and its x, y. A line without a
    label is named after its panel and left out of the legend when a labelled line of the same colour in the
    panel stands for it. Figures of several rows of panels get ``PANEL_HEIGHT_PX`` per row."""
    subplot_specs = {axes: spec for axes in figure.axes
                     if (spec := axes.get_subplotspec()) is not None and axes.get_visible()}
    geometry = next(iter(subplot_specs.values())).get_geometry()[:2] if subplot_specs else (1, 1)
    cells = {(spec.rowspan.start, spec.colspan.start): axes for axes, spec in subplot_specs.items()}
    panels = [cells[key] for key in sorted(cells)]  # plotly numbers its panels row by row
    specs: list[list[dict | None]] = [[{} if (row, col) in cells else None for col in range(geometry[1])]
                                      for row in range(geometry[0])]
    plot = make_subplots(rows=geometry[0], cols=geometry[1], horizontal_spacing=0.08, specs=specs,
                         vertical_spacing=min(0.3 / geometry[0], 0.12),
                         subplot_titles=[axes.get_title() for axes in panels])
    legend_names: set[str] = set()
    for axes in panels:
        spec = subplot_specs[axes]
        row, col = spec.rowspan.start + 1, spec.colspan.start + 1
        subplot = plot.get_subplot(row, col)
        x_ref, y_ref = (axis.plotly_name.replace("axis", "") for axis in (subplot.xaxis, subplot.yaxis))
        containers = [c for c in axes.containers if isinstance(c, ErrorbarContainer)]
        caps = {id(cap) for container in containers for cap in container.lines[1]}
        errors_of = {id(container.lines[0]): container for container in containers if container.lines[0] is not None}
        lines = sorted((line for line in axes.get_lines() if id(line) not in caps and line.get_visible()),
                       key=lambda line: line.get_zorder())
        labelled_colours = {to_hex(line.get_color()) for line in lines if not str(line.get_label()).startswith("_")}
        for line in lines:
            reference = _reference_line(axes, line)
            if reference is not None:
                style = {"line_color": to_hex(line.get_color()), "line_width": float(line.get_linewidth()),
                         "line_dash": DASHES.get(str(line.get_linestyle()), "solid")}
                if reference[0] == "v":
                    plot.add_vline(x=reference[1], row=row, col=col, **style)
                else:
                    plot.add_hline(y=reference[1], row=row, col=col, **style)
                continue
            container = errors_of.get(id(line))
            errors = {} if container is None else _error_arrays(
                container, np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float))
            plot.add_trace(_line_trace(axes, line, errors, legend_names, labelled_colours), row=row, col=col)
        _add_patches(plot, axes, row, col)
        _add_texts(plot, axes, x_ref, y_ref)
        plot.update_xaxes(title_text=axes.get_xlabel(), type="log" if axes.get_xscale() == "log" else "linear",
                          row=row, col=col, **_ticks(axes.xaxis))
        plot.update_yaxes(title_text=axes.get_ylabel(), type="log" if axes.get_yscale() == "log" else "linear",
                          autorange="reversed" if axes.yaxis_inverted() else True, row=row, col=col,
                          **_ticks(axes.yaxis))
    plot = _legend_layout(plot, figure.get_suptitle())
    if geometry[0] > 1:
        plot.update_layout(height=PANEL_HEIGHT_PX * geometry[0] + 120)
    return plot


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
