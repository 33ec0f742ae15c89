"""``foucault-bench simulate``: the Foucault pendulum seen from above, with sliders, or saved as an animation.

    foucault-bench simulate [--integrator NAME] [--model NAME] [--hours H] [--kh KH | --tol TOL]
                            [--earth-rate X] [--latitude DEG] [--length M] [--amplitude M]
                            [--save FILE.gif|FILE.mp4] [--frames N] [--fps N]

The window shows the bob's path in map view (East to the right, North up: the frame is x South, y East, z Up)
over ``--hours`` of swinging: the numeric solution of the chosen model by the chosen integrator and, overlaid,
the exact solution of the linear model (``models.analytic.linear_exact``); the release direction and the swing
plane's expected direction at the end, ψ₀ − ω sin φ · t (models/README.md "Frames and conventions"), are drawn
through the centre.
Sliders set Earth's rate (in multiples of the sidereal Ω_E, so that the precession shows within a few
swings), the latitude, the string length and the amplitude. The readout gives the precession rate measured on
the numeric solution's turning points (``bench.problems.turning_points.turning_points_from_grid`` and ``precession_rate``,
the procedure of the results table) against the textbook −ω sin φ, in degrees per hour, counter-clockwise
positive, and, for the spherical model, against Airy's finite-amplitude rate −ω sin φ (1 − (3/8)θ₀²).

The sliders move on grids (``SLIDERS``: steps, snap points at 0° and ±90° latitude, a logarithmic Earth's rate)
and bound each other (amplitude below length); the title and the slider labels print each value at its grid's
precision. The view stays on the swing: a path that leaves ``VIEW_BOUND`` amplitudes (a diverging integrator)
stops being drawn there, and the figure says when it left and when the run diverged. Old swings fade, and the
exact solution and the turning points are drawn on top of the trail.

``--save`` writes an animation of the same view instead (no display needed; ``reports.animation``). The
computation is ``bench.simulation.simulate``; this module draws its result (``SimulationView``), so both are
testable headless.
"""

from __future__ import annotations

import functools
import math
import os
import textwrap
from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np
from matplotlib.figure import Figure

from foucault_bench.bench.errors import InputError
from foucault_bench.integrators import STATUS_OK
from foucault_bench.integrators.registry import REGISTRY
from foucault_bench.reports.chart_style import integrator_style
from foucault_bench.bench.simulation import SimulationResult, simulate
from foucault_bench.bench.simulation_settings import SimulationSettings

DEGREES_PER_HOUR_PER_RAD_S = math.degrees(1.0) * 3600.0
WINDOW_TITLE = "foucault-bench simulate"
VIEW_BOUND = 1.2
"""Drawn region, in amplitudes from the centre: no model's bob goes past the amplitude (energy is conserved in the
rotating frame, up to the centrifugal term, O(Ω_E²L/g)), so a path beyond 1.2 A is numerically wrong; it is drawn
up to there and the figure says when it left."""
TRAIL_SEGMENTS = 8
"""The trail is drawn as this many pieces of equal duration, the older the fainter."""
TEXT_WRAP_CHARS = 46
"""Width (characters) at which messages in the figure are wrapped, so that they stay inside it."""


def drawn_until(result: SimulationResult) -> int:
    """Number of output points drawn: up to (not including) the first one that is not finite or lies beyond
    ``VIEW_BOUND`` amplitudes from the centre."""
    reach = np.hypot(result.numeric[:, 0], result.numeric[:, 1])
    outside = ~(reach <= VIEW_BOUND * result.settings.amplitude_m)
    return int(np.argmax(outside)) if outside.any() else len(result.t_s)


def map_view(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(East, North) of points given in the (South, East) frame: East = y, North = −x."""
    return np.asarray(y), -np.asarray(x)


@dataclass(frozen=True)
class SliderGrid:
    """One slider: the settings attribute it sets, its label, the values it can take (sorted, in the
    attribute's unit), the format each is printed with, and whether it moves on a logarithmic scale."""

    attribute: str
    label: str
    values: np.ndarray
    fmt: str
    log: bool = False

    def position(self, value: float) -> float:
        """Where ``value`` sits on the slider's axis (log10 of it on a logarithmic slider)."""
        return math.log10(value) if self.log else value

    def value(self, position: float) -> float:
        return 10.0**position if self.log else position


def _grid(low: float, high: float, step: float, snaps: tuple[float, ...] = (), capture: float = 0.0) -> np.ndarray:
    """The values low, low + step, …, high (rounded to the step's decimals), less those within 2·capture of a snap
    point (other than the point itself): the nearest value to a position within ``capture`` of a snap point is
    then the snap point."""
    decimals = max(0, -math.floor(math.log10(step)) + 1)
    values = np.round(low + step * np.arange(round((high - low) / step) + 1), decimals) + 0.0  # no −0.0
    keep = np.ones(values.shape, dtype=bool)
    for snap in snaps:
        keep &= ~((np.abs(values - snap) < 2.0 * capture) & (values != snap))
    return values[keep]


EARTH_RATE_FACTORS = np.unique(np.concatenate([_grid(0.1, 1.0, 0.01), _grid(1.0, 10.0, 0.1), _grid(10.0, 100.0, 1.0)]))
"""Earth's rate slider: 0.1-100 Ω_E with two significant digits (steps of 1 % to 10 %), on a log scale, so that
1-5 Ω_E takes as much of the slider as 10-50."""
SLIDERS = (
    SliderGrid("earth_rate_factor", "Earth's rate (× Ω_E)", EARTH_RATE_FACTORS, ".2g", log=True),
    SliderGrid("latitude_deg", "latitude φ (°)", _grid(-90.0, 90.0, 0.1, snaps=(-90.0, 0.0, 90.0), capture=0.5),
               ".1f"),
    SliderGrid("length_m", "length L (m)", _grid(1.0, 100.0, 0.5), ".1f"),
    SliderGrid("amplitude_m", "amplitude A (m)", _grid(0.05, 10.0, 0.05), ".2f"),
)
"""The sliders: latitude in 0.1° steps, snapping to the equator and the poles within 0.5°; length in 0.5 m
steps; amplitude in 5 cm steps, always below the length (and the length above it)."""
SLIDER_FORMATS = {grid.attribute: grid.fmt for grid in SLIDERS}


def format_setting(attribute: str, value: float) -> str:
    """``value`` at its slider's precision, or in full (``:g``) when that would round it (a value given on the
    command line off the slider's grid): what is printed is always what is simulated."""
    text = f"{value:{SLIDER_FORMATS.get(attribute, 'g')}}"
    return text if float(text) == value else f"{value:g}"


def allowed_values(grid: SliderGrid, settings: SimulationSettings) -> np.ndarray:
    """The grid's values compatible with the other settings: an amplitude below the length, a length above
    the amplitude."""
    if grid.attribute == "amplitude_m":
        return grid.values[grid.values < settings.length_m]
    if grid.attribute == "length_m":
        return grid.values[grid.values > settings.amplitude_m]
    return grid.values


def nearest_allowed(grid: SliderGrid, settings: SimulationSettings, value: float) -> float:
    """The allowed value nearest to ``value`` (on the slider's axis, so logarithmically for Earth's rate)."""
    values = allowed_values(grid, settings)
    if values.size == 0:  # a command-line setting no grid value fits (e.g. A ≥ 9.95 m with L < 10 m): keep it
        return getattr(settings, grid.attribute)
    if grid.log:
        return float(values[np.argmin(np.abs(np.log10(values) - math.log10(max(value, 1e-300))))])
    return float(values[np.argmin(np.abs(values - value))])


def title_text(settings: SimulationSettings) -> str:
    return (f"Seen from above: L = {format_setting('length_m', settings.length_m)} m, "
            f"A = {format_setting('amplitude_m', settings.amplitude_m)} m, "
            f"φ = {format_setting('latitude_deg', settings.latitude_deg)}°, "
            f"ω = {format_setting('earth_rate_factor', settings.earth_rate_factor)} Ω_E")


def _wrap(text: str) -> list[str]:
    return textwrap.wrap(text, width=TEXT_WRAP_CHARS, break_long_words=True, break_on_hyphens=False)


def readout_text(result: SimulationResult) -> str:
    """The rate readout: measured (turning points) against −ω sin φ and, for the spherical model, Airy's rate,
    °/h, counter-clockwise positive."""
    s = result.settings
    expected = result.expected_rate_rad_s * DEGREES_PER_HOUR_PER_RAD_S
    measured = result.measured_rate_rad_s * DEGREES_PER_HOUR_PER_RAD_S
    stderr = result.measured_rate_stderr_rad_s * DEGREES_PER_HOUR_PER_RAD_S
    lines = [f"{s.integrator}, {s.model} model, {s.hours:g} h", f"{len(result.turning_points)} turning points"]
    measured_text = f"{measured:+.4f} ± {stderr:.1e}" if math.isfinite(measured) else "– (not measured)"
    lines += [
        "precession rate (°/h, counter-clockwise +)",
        f"  measured:          {measured_text}",
        f"  expected −ω sin φ: {expected:+.4f}",
    ]
    if result.airy_rate_rad_s is not None:
        lines += [f"  Airy −ω sin φ (1 − 3θ₀²/8): {result.airy_rate_rad_s * DEGREES_PER_HOUR_PER_RAD_S:+.4f}",
                  "  (finite swing θ₀ = A/L; Airy 1851)"]
    lines.append(f"  (ω = {format_setting('earth_rate_factor', s.earth_rate_factor)} Ω_E, "
                 f"φ = {format_setting('latitude_deg', s.latitude_deg)}°)")
    return "\n".join(lines)


def notice_text(result: SimulationResult) -> str:
    """What the view must say about the numeric path: that the run diverged and when, and where the drawing stops."""
    lines = []
    if result.status != STATUS_OK:
        message = result.message if result.message.startswith(result.status) else f"{result.status}: {result.message}"
        lines += _wrap(f"{result.settings.integrator} run {message}")
    drawn = drawn_until(result)
    if drawn < len(result.t_s):
        lines += _wrap(f"the path leaves {VIEW_BOUND:g} A from the centre at t = {result.t_s[drawn]:.4g} s: "
                       "not drawn after that")
    return "\n".join(lines)


class SimulationView:
    """The map-view axes, their artists and the readout; ``update`` redraws them for new settings."""

    def __init__(self, figure: Figure, settings: SimulationSettings, axes_rect: tuple[float, float, float, float]):
        self.figure = figure
        self.settings = settings
        self.axes = figure.add_axes(axes_rect)
        style = integrator_style(settings.integrator, REGISTRY[settings.integrator].family)
        # the trail below everything, older pieces fainter; the exact solution and the turning points on top
        self.trail = [self.axes.plot([], [], color=style["color"], linewidth=0.8, zorder=1,
                                     label=f"{settings.integrator}, {settings.model} model (older: fainter)"
                                     if piece == TRAIL_SEGMENTS - 1 else None)[0]
                      for piece in range(TRAIL_SEGMENTS)]
        self.analytic_line, = self.axes.plot([], [], color="black", linewidth=0.5, alpha=0.8, linestyle=(0, (4, 4)),
                                             zorder=3, label="exact solution, linear model")
        self.turning_dots, = self.axes.plot([], [], ".", color="black", markersize=3, zorder=4,
                                            label="turning points")
        self.release_line, = self.axes.plot([], [], color="grey", linewidth=1.2, zorder=2, label="release direction")
        self.expected_line, = self.axes.plot([], [], color="#e377c2", linewidth=2.5, zorder=2,
                                             label="expected swing plane now")
        self.bob, = self.axes.plot([], [], "o", color=style["color"], markersize=8, markeredgecolor="black", zorder=5)
        self.axes.set_aspect("equal", adjustable="box")
        self.axes.set_xlabel("East (m)")
        self.axes.set_ylabel("North (m)")
        self.axes.grid(True, alpha=0.3)
        self.axes.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
        self.clock = self.axes.text(0.02, 0.02, "", transform=self.axes.transAxes, fontsize=9)
        self.notice = self.axes.text(0.5, 0.97, "", transform=self.axes.transAxes, fontsize=9, color="#b00000",
                                     ha="center", va="top", zorder=6,
                                     bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "#b00000"})
        self.readout = figure.text(axes_rect[0] + axes_rect[2] + 0.02, axes_rect[1], "", fontsize=9,
                                   family="monospace", va="bottom")
        self.result: SimulationResult | None = None

    def update(self, settings: SimulationSettings) -> None:
        """Recompute and redraw; parameters the model refuses show as a message and leave the plot empty."""
        self.settings = settings
        self.axes.set_title(title_text(settings))
        try:
            self.result = simulate(settings)
        except ValueError as error:
            self.result = None
            for line in (*self.trail, self.analytic_line, self.turning_dots, self.expected_line, self.release_line,
                         self.bob):
                line.set_data([], [])
            self.clock.set_text("")
            self.readout.set_text("")
            self.notice.set_text("\n".join(_wrap(f"cannot simulate: {error}")))
            self.notice.set_visible(True)
            return
        self.show_until(len(self.result.t_s) - 1)
        self.readout.set_text(readout_text(self.result))
        notice = notice_text(self.result)
        self.notice.set_text(notice)
        self.notice.set_visible(bool(notice))
        radius = 1.1 * VIEW_BOUND * settings.amplitude_m
        self.axes.set_xlim(-radius, radius)
        self.axes.set_ylim(-radius, radius)

    def drawn_path(self) -> tuple[np.ndarray, np.ndarray]:
        """(East, North) of the numeric path as drawn (the trail's pieces joined)."""
        pieces = [np.asarray(line.get_data(), dtype=float) for line in self.trail]
        joined = [pieces[0]] + [piece[:, 1:] for piece in pieces[1:] if piece.shape[1]]
        return tuple(np.concatenate(joined, axis=1))

    def show_until(self, index: int) -> None:
        """Draw the paths up to output index ``index`` and the expected swing plane at that time."""
        result = self.result
        assert result is not None
        stop = index + 1
        shown = min(stop, drawn_until(result))
        edges = np.linspace(0, max(shown - 1, 0), TRAIL_SEGMENTS + 1).round().astype(int)
        for piece, line in enumerate(self.trail):
            first, last = edges[piece], edges[piece + 1] + 1 if shown else 0
            line.set_data(*map_view(result.numeric[first:last, 0], result.numeric[first:last, 1]))
            line.set_alpha(0.15 + 0.85 * (piece + 1) / TRAIL_SEGMENTS)
        self.analytic_line.set_data(*map_view(result.analytic[:stop, 0], result.analytic[:stop, 1]))
        points = result.turning_points[result.turning_points[:, 0] <= result.t_s[index]]
        self.turning_dots.set_data(*map_view(points[:, 1], points[:, 2]))
        params = result.settings.params()
        amplitude = params.amplitude_m
        release = math.radians(params.release_azimuth_deg)
        expected = release + result.plane_rate_rad_s * result.t_s[index]
        ends = np.array([-1.0, 1.0]) * amplitude
        self.release_line.set_data(*map_view(ends * math.cos(release), ends * math.sin(release)))
        self.expected_line.set_data(*map_view(ends * math.cos(expected), ends * math.sin(expected)))
        bob = min(index, shown - 1)
        self.bob.set_data(*(map_view(result.numeric[bob:bob + 1, 0], result.numeric[bob:bob + 1, 1]) if shown
                            else (np.empty(0), np.empty(0))))
        self.clock.set_text(f"t = {result.t_s[index] / 3600.0:.2f} h")


class InteractiveSimulation:
    """A figure with the view and one slider per entry of ``SLIDERS``; moving a slider moves it to the nearest
    allowed value (``nearest_allowed``) and recomputes."""

    def __init__(self, figure: Figure, settings: SimulationSettings):
        from matplotlib.widgets import Slider

        self.view = SimulationView(figure, settings, (0.07, 0.36, 0.5, 0.58))
        self.sliders = {}
        self.grids = {grid.attribute: grid for grid in SLIDERS}
        for row, grid in enumerate(SLIDERS):
            slider_axes = figure.add_axes((0.2, 0.22 - 0.05 * row, 0.5, 0.03))
            start = min(max(getattr(settings, grid.attribute), grid.values[0]), grid.values[-1])  # e.g. rate 0
            slider = Slider(slider_axes, grid.label, grid.position(grid.values[0]), grid.position(grid.values[-1]),
                            valinit=grid.position(start))
            slider.on_changed(functools.partial(self._changed, grid.attribute))
            self.sliders[grid.attribute] = slider
        self.bound_marks = {name: self.sliders[name].ax.axvline(math.nan, color="#b00000", linewidth=1.5)
                            for name in ("amplitude_m", "length_m")}
        self.view.update(settings)
        self._show_values()

    def set_value(self, attribute: str, value: float) -> None:
        """Move a slider to ``value`` (in the attribute's unit, also for a logarithmic slider), as a user would."""
        self.sliders[attribute].set_val(self.grids[attribute].position(value))

    def _changed(self, attribute: str, position: float) -> None:
        grid = self.grids[attribute]
        allowed = nearest_allowed(grid, self.view.settings, grid.value(position))
        if grid.position(allowed) != position:  # off the grid or past a bound: move there (which calls back)
            self.sliders[attribute].set_val(grid.position(allowed))
            return
        self.view.update(replace(self.view.settings, **cast(dict[str, Any], {attribute: allowed})))
        self._show_values()
        self.view.figure.canvas.draw_idle()

    def _show_values(self) -> None:
        """Each slider's value at its precision, and where the amplitude and length bound each other."""
        settings = self.view.settings
        for attribute, slider in self.sliders.items():
            slider.valtext.set_text(format_setting(attribute, getattr(settings, attribute)))
        self.bound_marks["amplitude_m"].set_xdata([settings.length_m])
        self.bound_marks["length_m"].set_xdata([settings.amplitude_m])


def open_window(settings: SimulationSettings) -> InteractiveSimulation:
    """The interactive figure in a pyplot window titled ``WINDOW_TITLE`` (shown by ``plt.show()``)."""
    import matplotlib.pyplot as plt

    return InteractiveSimulation(plt.figure(num=WINDOW_TITLE, figsize=(12, 8)), settings)


def show_interactive(settings: SimulationSettings) -> int:
    """Open the interactive window (``InputError`` when there is no display or GUI backend); exit status 0
    when the last simulation shown ran, 1 otherwise."""
    import matplotlib

    if os.name != "nt" and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise InputError("no display for an interactive window: use --save FILE.gif (or .mp4) instead")
    import matplotlib.pyplot as plt

    if matplotlib.get_backend().lower() in ("agg", "pdf", "ps", "svg", "cairo", "template"):
        raise InputError(f"matplotlib's backend {matplotlib.get_backend()!r} cannot open a window: "
                         "install a GUI toolkit (e.g. tkinter) or use --save FILE.gif")
    simulation = open_window(settings)  # holds the sliders while the window is open
    plt.show()
    return 0 if simulation.view.result is not None else 1
