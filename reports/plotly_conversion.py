"""matplotlib figures as plotly figures: the report's charts of curves (the study tables, the seed section, the
ensembles) are drawn with matplotlib and shown on the page through ``from_matplotlib``.

The conversion keeps what a reader reads off a chart: every line and marker with its colour, dash and marker
symbol (``reports.interactive.SYMBOLS``), error bars, shaded bands (``PolyCollection``), texts placed in axes
coordinates, log or linear axes with their limits and fixed ticks, titles, and the legend (families grouped as in
``reports.interactive``). ``tests/test_report_oracle_charts.py`` checks that no drawn element is lost.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_hex
from matplotlib.container import ErrorbarContainer
from matplotlib.figure import Figure as MplFigure
from matplotlib.ticker import FixedLocator

from foucault_bench.reports.interactive import SYMBOLS, legend_layout
from foucault_bench.reports.plotly_figure import Plot, Trace, data_array, scatter, subplots

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
            "type": "data", "symmetric": False, "array": data_array(high - centre),
            "arrayminus": data_array(centre - low),
            "color": to_hex(collection.get_colors()[0]), "thickness": 1, "width": 3}
    return errors


def _line_trace(axes, line, errors: dict[str, Any], legend_names: set[str], labelled_colours: set[str]) -> Trace:
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
    return scatter(
        x=data_array(xy[:, 0]), y=data_array(xy[:, 1]), mode=mode, name=name, legendgroup=name, showlegend=shown,
        line={"color": colour, "dash": DASHES.get(linestyle, "solid"), "width": float(line.get_linewidth())},
        marker=_marker(line), opacity=line.get_alpha() if line.get_alpha() is not None else 1.0,
        hovertemplate=f"{name}<br>x %{{x:.4g}}<br>y %{{y:.4g}}<extra></extra>", **errors)


def _add_patches(plot: Plot, axes, row: int, col: int) -> None:
    """Shaded spans (``axvspan``/``axhspan``: rectangles across the axes) as plotly rectangles, other patches
    and filled areas (``fill_between``) as filled traces in data coordinates."""
    for patch in axes.patches:
        path = patch.get_path().vertices
        fractions = _axes_fractions(axes, patch.get_transform(), path)
        data = _data_coordinates(axes, patch.get_transform(), path)
        face = patch.get_facecolor()
        style = {"fillcolor": to_hex(face), "opacity": float(face[3]), "line": {"width": 0}, "layer": "below"}
        if np.allclose(sorted({round(v, 9) for v in fractions[:, 1]}), [0.0, 1.0]):
            plot.add_spanning("vrect", float(data[:, 0].min()), float(data[:, 0].max()), row, col, **style)
        elif np.allclose(sorted({round(v, 9) for v in fractions[:, 0]}), [0.0, 1.0]):
            plot.add_spanning("hrect", float(data[:, 1].min()), float(data[:, 1].max()), row, col, **style)
        else:
            plot.add_trace(scatter(x=data_array(data[:, 0]), y=data_array(data[:, 1]), fill="toself", mode="lines",
                                   showlegend=False, fillcolor=to_hex(face, keep_alpha=True), line={"width": 0},
                                   name=str(patch.get_label()), hoverinfo="skip"), row=row, col=col)
    for collection in axes.collections:
        if not isinstance(collection, PolyCollection):
            continue
        faces: Any = collection.get_facecolor()  # an N×4 RGBA array (typed as one colour)
        for path in collection.get_paths():
            data = _data_coordinates(axes, collection.get_transform(), path.vertices)
            plot.add_trace(scatter(x=data_array(data[:, 0]), y=data_array(data[:, 1]), fill="toself", mode="lines",
                                   showlegend=False, fillcolor=to_hex(faces[0], keep_alpha=True),
                                   line={"width": 0}, name=str(collection.get_label()), hoverinfo="skip"),
                           row=row, col=col)


def _add_texts(plot: Plot, axes, x_ref: str, y_ref: str) -> None:
    """Texts written on a panel, at the same place relative to its axes."""
    for text in axes.texts:
        if not text.get_visible() or not text.get_text().strip():
            continue
        position = _axes_fractions(axes, text.get_transform(), np.array(text.get_position()))[0]
        plot.add_annotation(x=float(position[0]), y=float(position[1]), xref=f"{x_ref} domain",
                            yref=f"{y_ref} domain", text=text.get_text().strip(), showarrow=False,
                            xanchor={"center": "center", "right": "right"}.get(text.get_horizontalalignment(), "left"),
                            font={"size": 10, "color": to_hex(text.get_color())})


def from_matplotlib(figure: MplFigure) -> Plot:
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
    plot = subplots(rows=geometry[0], cols=geometry[1], horizontal_spacing=0.08, specs=specs,
                    vertical_spacing=min(0.3 / geometry[0], 0.12), titles=[axes.get_title() for axes in panels])
    legend_names: set[str] = set()
    for axes in panels:
        spec = subplot_specs[axes]
        row, col = spec.rowspan.start + 1, spec.colspan.start + 1
        x_ref, y_ref = plot.cells[(row, col)]
        containers = [c for c in axes.containers if isinstance(c, ErrorbarContainer)]
        caps = {id(cap) for container in containers for cap in container.lines[1]}
        errors_of = {id(container.lines[0]): container for container in containers if container.lines[0] is not None}
        lines = sorted((line for line in axes.get_lines() if id(line) not in caps and line.get_visible()),
                       key=lambda line: line.get_zorder())
        labelled_colours = {to_hex(line.get_color()) for line in lines if not str(line.get_label()).startswith("_")}
        for line in lines:
            reference = _reference_line(axes, line)
            if reference is not None:
                style = {"color": to_hex(line.get_color()), "width": float(line.get_linewidth()),
                         "dash": DASHES.get(str(line.get_linestyle()), "solid")}
                plot.add_spanning(f"{reference[0]}line", reference[1], reference[1], row, col, line=style)
                continue
            container = errors_of.get(id(line))
            errors = {} if container is None else _error_arrays(
                container, np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float))
            plot.add_trace(_line_trace(axes, line, errors, legend_names, labelled_colours), row=row, col=col)
        _add_patches(plot, axes, row, col)
        _add_texts(plot, axes, x_ref, y_ref)
        plot.update_axes("x", title={"text": axes.get_xlabel()},
                         type="log" if axes.get_xscale() == "log" else "linear", row=row, col=col,
                         **_ticks(axes.xaxis))
        plot.update_axes("y", title={"text": axes.get_ylabel()},
                         type="log" if axes.get_yscale() == "log" else "linear",
                         autorange="reversed" if axes.yaxis_inverted() else True, row=row, col=col,
                         **_ticks(axes.yaxis))
    plot = legend_layout(plot, figure.get_suptitle())
    if geometry[0] > 1:
        plot.update_layout(height=PANEL_HEIGHT_PX * geometry[0] + 120)
    return plot
