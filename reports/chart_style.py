"""The report's chart conventions and the pieces every static chart is drawn from: family colours, integrator
markers and line styles, log axes, edge markers for runs without a plottable value, the sweeps of results rows
and the Pareto staircase. The charts themselves are ``reports.charts`` (results rows) and ``reports.study_charts``
(study tables); ``reports.interactive`` draws the same conventions with plotly.

Conventions shared by every chart:

* colour = integrator family (``family_colour``, the same in every chart and report), marker and line
  pattern = integrator within its family, solid-type lines = fixed-step sweeps (k·h), dashed-type lines =
  tolerance sweeps;
* runs that diverged, failed or timed out are never dropped: they are drawn as a marker on the top edge of the
  axes at their cost (▲ diverged, ✕ failed or timed out; at the left edge when the cost is unknown); an ok run
  without a finite, positive value is drawn on the bottom edge (▽); the interactive charts draw the same
  markers above and below their data;
* log axes wherever values span decades; axis labels carry units.

Figures are built with ``matplotlib.figure.Figure`` (no pyplot state), so importing this module never changes
the backend an interactive session uses; saving renders with Agg.
"""

from __future__ import annotations

import colorsys
import math
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd
from matplotlib import colors
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import LogFormatterSciNotation

from foucault_bench.bench.schema import setting_label
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_OK
from foucault_bench.integrators.registry import REGISTRY

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


def ordered_integrators(frame: pd.DataFrame) -> list[tuple[str, str]]:
    """(integrator, family) pairs present in ``frame``, grouped by family, then by name."""
    pairs = frame[["integrator", "family"]].drop_duplicates()
    return sorted(((row.integrator, row.family) for row in pairs.itertuples()), key=lambda p: (p[1], p[0]))


_SUPERSCRIPTS = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


class TextLogFormatter(LogFormatterSciNotation):
    """matplotlib's log-axis labels (10⁻⁶, 2×10⁻⁶, 1) as plain Unicode text instead of mathtext: the same
    numbers and look, without parsing a mathtext expression per label and per output format (which was a quarter
    of a chart's drawing time)."""

    def __call__(self, x: float, pos: int | None = None) -> str:
        label = super().__call__(x, pos)
        match = re.fullmatch(r"\$\\mathdefault\{(.*)\}\$", label)
        if match is None:
            return label
        text = match.group(1).replace("\\times", "×")
        text = re.sub(r"\^\{([^}]*)\}", lambda power: power.group(1).translate(_SUPERSCRIPTS), text)
        return text[:1].replace("-", "−") + text[1:]


def set_log_scales(axes: Axes, x: bool = True, y: bool = True) -> None:
    """Log scale on x and/or y, labelled by ``TextLogFormatter``. An axis without any finite positive data (every
    run failed, say) gets the placeholder limits 1 to 10 and the panel says so, instead of failing to draw."""
    empty = False
    for use, interval, set_scale, set_limits, axis in (
            (x, axes.dataLim.intervalx, axes.set_xscale, axes.set_xlim, axes.xaxis),
            (y, axes.dataLim.intervaly, axes.set_yscale, axes.set_ylim, axes.yaxis)):
        if not use:
            continue
        set_scale("log")
        axis.set_major_formatter(TextLogFormatter(base=10.0))
        axis.set_minor_formatter(TextLogFormatter(base=10.0, labelOnlyBase=False))
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
    """Write ``stem``.png (120 dpi) and ``stem``.svg; return the stem. The layout (constrained, where the figure
    asks for it) is computed for the PNG and kept for the SVG: a second pass would place the same boxes again
    (sizes are in points, independent of the dpi) at a third of a chart's drawing time."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(stem.with_suffix(".png"), dpi=120)
    figure.set_layout_engine("none")
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
        statuses = Counter([*self.diverged["status"], *self.failed["status"]])  # in order of first appearance
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
    none = frame.iloc[:0]

    def rows(selected: np.ndarray) -> pd.DataFrame:
        return frame.iloc[selected] if selected.size else none  # most selections are empty: no copy for them

    found = []
    for integrator, family in ordered_integrators(frame):
        mine = names == integrator
        drawn = np.flatnonzero(mine & ok & plottable)
        drawn = drawn[np.argsort(along[drawn], kind="stable")]
        found.append(Sweep(integrator, family, bool(tolerance_sweep[mine].any()),
                           frame.iloc[drawn].assign(**{y_column: y[drawn]}),
                           rows(np.flatnonzero(mine & ok & ~plottable)),
                           rows(np.flatnonzero(mine & diverged)),
                           rows(np.flatnonzero(mine & ~ok & ~diverged))))
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
