"""plotly figures as plain data: the report's interactive charts are built as the dictionaries plotly.js reads
(``{"data": [trace, ...], "layout": {...}}``), not as ``plotly.graph_objects`` objects.

``plotly.graph_objects`` checks every property against plotly's schema as it is set (nested objects, magic
underscores, data arrays copied); in a report of the default matrix that checking was most of the time spent
drawing the work-precision charts (bench/PERF.md "The report in plain plotly data"). Here a trace is a
``dict`` named as plotly.js names its properties, and ``Plot.to_json`` writes what ``go.Figure.to_json`` wrote
for the same figure: data arrays in plotly's binary encoding (``dtype``/``bdata``) and the ``plotly_white``
template in full. The panels' layout is plotly's own (``plotly.subplots.make_subplots``, computed once per
grid), as are the binary encoding and the JSON writer (``plotly.io``). ``tests/test_plotly_figure.py`` checks
that plotly's validating objects accept every chart kind of the report unchanged and write the same JSON.
"""

from __future__ import annotations

import copy
import functools
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
import plotly.io as pio
from _plotly_utils.basevalidators import copy_to_readonly_numpy_array, is_homogeneous_array
from _plotly_utils.utils import to_typed_array_spec
from plotly.subplots import make_subplots

TEMPLATE = "plotly_white"
"""The template of every chart (written in full into each figure, as plotly does)."""

Trace = dict[str, Any]


def scatter(**properties: Any) -> Trace:
    """A scatter trace with ``properties`` as plotly.js names them (nested objects as dicts: ``line={"color":
    ...}``, never ``line_color``); data arrays (``x``, ``y``, error bars) as ``data_array`` makes them."""
    return {**properties, "type": "scatter"}


def data_array(values: Any) -> np.ndarray:
    """A data array as plotly's validation makes it (a read-only numpy copy of a list, Series or array).

    A numeric numpy array or pandas Series (numpy dtype) is copied here as ``copy_to_readonly_numpy_array``
    copies it (a C-contiguous copy, read-only) without its conversion layer, which costs a report of the default
    matrix seconds of its thousands of calls; anything else goes through it."""
    if isinstance(values, pd.Series) and isinstance(values.dtype, np.dtype):
        values = values.to_numpy()
    if type(values) is np.ndarray and values.dtype.kind in "uif":
        copied = np.ascontiguousarray(values.copy())
        copied.flags.writeable = False
        return copied
    return copy_to_readonly_numpy_array(values)


@functools.cache
def _grid(rows: int, cols: int, options: str) -> tuple[str, dict[tuple[int, int], tuple[str, str]]]:
    """``make_subplots``' layout (JSON, without the template) and each panel's axes for a grid with ``options``
    (JSON of its keyword arguments; subplot titles given as placeholders)."""
    figure = make_subplots(rows=rows, cols=cols, **json.loads(options))
    layout = figure.to_dict()["layout"]
    layout.pop("template", None)
    cells = {}
    for row in range(1, rows + 1):
        for col in range(1, cols + 1):
            try:
                subplot = figure.get_subplot(row, col)
            except Exception:  # noqa: BLE001 - plotly raises a bare Exception for an empty cell of the grid
                continue
            if subplot is not None:
                cells[(row, col)] = (subplot.xaxis.plotly_name.replace("axis", ""),
                                     subplot.yaxis.plotly_name.replace("axis", ""))
    return json.dumps(layout), cells


@functools.cache
def _template() -> dict[str, Any]:
    return copy.deepcopy(pio.templates[TEMPLATE].to_plotly_json())


def _merge(target: dict[str, Any], update: dict[str, Any]) -> None:
    """``update`` merged into ``target``, nested dicts key by key (plotly's ``update``)."""
    for key, value in update.items():
        if isinstance(value, dict) and isinstance(target.get(key), dict):
            _merge(target[key], value)
        else:
            target[key] = value


def _encoded(value: Any) -> Any:
    """``value`` with every data array in plotly's binary encoding (``_plotly_utils.utils.convert_to_base64``,
    without changing ``value``)."""
    if isinstance(value, dict):
        return {key: to_typed_array_spec(item) if is_homogeneous_array(item) else _encoded(item)
                for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        if not any(isinstance(item, (dict, list, tuple)) for item in value):
            return list(value)  # a list of values (customdata rows, symbols) holds nothing to encode
        return [_encoded(item) for item in value]
    return value


@dataclass
class Plot:
    """A plotly figure as plain data: ``data`` (traces) and ``layout``, on a grid of panels (``subplots``)."""

    data: list[Trace] = field(default_factory=list)
    layout: dict[str, Any] = field(default_factory=dict)
    cells: dict[tuple[int, int], tuple[str, str]] = field(default_factory=dict)
    """(row, col) → the panel's axes ("x2", "y2")."""

    def add_trace(self, trace: Trace, row: int | None = None, col: int | None = None) -> None:
        """Append ``trace``, in panel (``row``, ``col``) when given."""
        if row is not None and col is not None:
            x_axis, y_axis = self.cells[(row, col)]
            trace = {**trace, "xaxis": x_axis, "yaxis": y_axis}
        self.data.append(trace)

    def update_layout(self, **properties: Any) -> None:
        _merge(self.layout, properties)

    def update_axes(self, letter: str, row: int | None = None, col: int | None = None, **properties: Any) -> None:
        """Merge ``properties`` into the ``letter`` ("x" or "y") axis of panel (``row``, ``col``), or into every
        such axis when no panel is given."""
        if row is not None and col is not None:
            names = ["xaxis" + self.cells[(row, col)][0][1:] if letter == "x"
                     else "yaxis" + self.cells[(row, col)][1][1:]]
        else:
            names = [name for name in self.layout if name.startswith(f"{letter}axis")]
        for name in names:
            _merge(self.layout.setdefault(name, {}), properties)

    def _panel_has_traces(self, row: int, col: int) -> bool:
        """Whether a trace is drawn in the panel: plotly adds a shape spanning a panel only then."""
        axes = self.cells[(row, col)]
        return any((trace.get("xaxis", "x"), trace.get("yaxis", "y")) == axes for trace in self.data)

    def add_spanning(self, kind: str, low: float, high: float, row: int, col: int, **properties: Any) -> None:
        """What plotly's ``add_vline``, ``add_hline`` (``low`` = ``high``), ``add_vrect`` and ``add_hrect`` (``kind``)
        add in panel (``row``, ``col``): a line or band across the panel from ``low`` to ``high`` on its x axis
        ("v") or y axis ("h"); like plotly, nothing in a panel without traces."""
        if not self._panel_has_traces(row, col):
            return
        x_axis, y_axis = self.cells[(row, col)]
        shape: dict[str, Any] = {"type": "line" if kind.endswith("line") else "rect"}
        if kind.startswith("v"):
            shape.update(x0=low, x1=high, xref=x_axis, y0=0, y1=1, yref=f"{y_axis} domain")
        else:
            shape.update(x0=0, x1=1, xref=f"{x_axis} domain", y0=low, y1=high, yref=y_axis)
        _merge(shape, properties)
        self.layout.setdefault("shapes", []).append(shape)

    def add_annotation(self, **properties: Any) -> None:
        self.layout.setdefault("annotations", []).append(properties)

    def figure(self) -> dict[str, Any]:
        """The figure as plotly.js reads it (``data``, ``layout`` with the template), arrays not yet encoded."""
        return {"data": self.data, "layout": {**self.layout, "template": _template()}}

    def to_json(self) -> str:
        """The JSON ``go.Figure.to_json`` writes for this figure (binary data arrays; ``plotly.io``'s writer)."""
        return pio.to_json(_encoded(self.figure()), validate=False)


def subplots(rows: int = 1, cols: int = 1, titles: list[str] | None = None, **options: Any) -> Plot:
    """An empty ``Plot`` of ``rows`` × ``cols`` panels laid out as ``make_subplots(rows, cols, **options,
    subplot_titles=titles)`` lays them out (the layout is computed once per grid and options)."""
    placeholders = [f"title {index}" for index in range(len(titles))] if titles else None
    layout_json, cells = _grid(rows, cols, json.dumps({**options, "subplot_titles": placeholders}, sort_keys=True))
    layout = json.loads(layout_json)
    if titles:
        annotations = layout.pop("annotations")
        kept = [{**annotation, "text": title} for annotation, title in zip(annotations, titles, strict=True) if title]
        if kept:
            layout["annotations"] = kept
    return Plot([], layout, dict(cells))
