"""``foucault-bench simulate``: the Foucault pendulum seen from above, with sliders, or saved as an animation.

    foucault-bench simulate [--integrator NAME] [--model NAME] [--hours H] [--kh KH | --tol TOL]
                            [--earth-rate X] [--latitude DEG] [--length M] [--amplitude M]
                            [--save FILE.gif|FILE.mp4] [--frames N] [--fps N]

The window shows the bob's path in map view (East to the right, North up: the frame is x South, y East, z Up) over
``--hours`` of swinging: the numeric solution of the chosen model by the chosen integrator and, overlaid, the
exact solution of the linear model (``models.analytic.linear_exact``); the release direction and the swing plane's
expected direction at the end, ψ₀ − ω sin φ · t (models/README.md "Frames and conventions"), are drawn through the
centre. Sliders set Earth's rate (in multiples of the sidereal Ω_E, so that the precession shows within a few
swings), the latitude, the string length and the amplitude. The readout gives the precession rate measured on the
numeric solution's turning points (``bench.verdicts.turning_points.turning_points_from_grid`` and
``precession_rate``, the procedure of the results table) against the textbook −ω sin φ, in degrees per hour,
counter-clockwise positive.

``--save`` writes an animation of the same view instead (no display needed): GIF with Pillow, MP4 with ffmpeg
(a clear error when ffmpeg is not installed). The computation (``simulate``) is separate from the drawing
(``SimulationView``), so both are testable headless.
"""

from __future__ import annotations

import math
import os
import textwrap
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.verdicts.turning_points import grid_accelerations, precession_rate, turning_points_from_grid
from foucault_bench.integrators import STATUS_OK, Problem, get_integrator
from foucault_bench.integrators.registry import REGISTRY
from foucault_bench.models import get_model
from foucault_bench.models.analytic import linear_exact
from foucault_bench.reports.charts import integrator_style
from foucault_bench.reports.simulation_settings import SimulationSettings

DEGREES_PER_HOUR_PER_RAD_S = math.degrees(1.0) * 3600.0
OUTPUT_POINTS_PER_PERIOD = 16
"""Output grid density: 16 points per small-swing period (turning points need fewer than a quarter period
between samples, ``bench.verdicts``; the extra density draws the swing smoothly)."""
MAX_OUTPUT_POINTS = 400_000
"""Largest output grid the command accepts (the view redraws it on every slider move)."""


ANIMATION_DPI = 80
"""Resolution of saved animations (a 10 × 6 in figure: 800 × 480 pixels)."""


@dataclass
class SimulationResult:
    """Numeric and analytic paths on one grid, turning points, measured and expected rates (rad/s)."""

    settings: SimulationSettings
    t_s: np.ndarray
    numeric: np.ndarray
    analytic: np.ndarray
    turning_points: np.ndarray
    measured_rate_rad_s: float
    measured_rate_stderr_rad_s: float
    expected_rate_rad_s: float
    status: str
    message: str


def simulate(settings: SimulationSettings) -> SimulationResult:
    """Integrate the settings' model with its integrator and measure the precession (``ValueError`` for
    parameters the model refuses, e.g. an amplitude not below the length)."""
    params = settings.params()
    period = params.small_swing_period_s
    duration = settings.hours * 3600.0
    intervals = max(1, math.ceil(OUTPUT_POINTS_PER_PERIOD * duration / period))
    t = np.linspace(0.0, duration, intervals + 1)
    model = get_model(settings.model)
    integrator = get_integrator(settings.integrator)
    problem = Problem(model=model, params=params, t_out=t)
    if integrator.adaptive:
        solution = integrator.solve(problem, tol=settings.setting)
    else:
        solution = integrator.solve(problem, step_s=settings.setting / params.pendulum_frequency_rad_s)
    points = turning_points_from_grid(t, solution.y, grid_accelerations(model, params, solution.y),
                                      include_release=True)
    rate, stderr = precession_rate(points) if solution.status == STATUS_OK else (math.nan, math.nan)
    return SimulationResult(settings=settings, t_s=t, numeric=solution.y, analytic=linear_exact(params, t),
                            turning_points=points, measured_rate_rad_s=rate, measured_rate_stderr_rad_s=stderr,
                            expected_rate_rad_s=params.textbook_precession_rate_rad_s, status=solution.status,
                            message=solution.message)


def map_view(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(East, North) of points given in the (South, East) frame: East = y, North = −x."""
    return np.asarray(y), -np.asarray(x)


def readout_text(result: SimulationResult) -> str:
    """The rate readout: measured (turning points) against −ω sin φ, °/h, counter-clockwise positive."""
    s = result.settings
    expected = result.expected_rate_rad_s * DEGREES_PER_HOUR_PER_RAD_S
    measured = result.measured_rate_rad_s * DEGREES_PER_HOUR_PER_RAD_S
    stderr = result.measured_rate_stderr_rad_s * DEGREES_PER_HOUR_PER_RAD_S
    lines = [f"{s.integrator}, {s.model} model, {s.hours:g} h", f"{len(result.turning_points)} turning points"]
    if result.status != STATUS_OK:
        lines += textwrap.wrap(f"run {result.status}: {result.message}", width=48)
    measured_text = f"{measured:+.4f} ± {stderr:.1e}" if math.isfinite(measured) else "– (not measured)"
    lines += [
        "precession rate (°/h, counter-clockwise +)",
        f"  measured:          {measured_text}",
        f"  expected −ω sin φ: {expected:+.4f}",
        f"  (ω = {s.earth_rate_factor:g} Ω_E, φ = {s.latitude_deg:g}°)",
    ]
    return "\n".join(lines)


class SimulationView:
    """The map-view axes, their artists and the readout; ``update`` redraws them for new settings."""

    def __init__(self, figure: Figure, settings: SimulationSettings, axes_rect: tuple[float, float, float, float]):
        self.figure = figure
        self.settings = settings
        self.axes = figure.add_axes(axes_rect)
        style = integrator_style(settings.integrator, REGISTRY[settings.integrator].family)
        self.numeric_line, = self.axes.plot([], [], color=style["color"], linewidth=0.8,
                                            label=f"{settings.integrator}, {settings.model} model")
        self.analytic_line, = self.axes.plot([], [], color="black", linewidth=0.4, alpha=0.6, linestyle=(0, (4, 4)),
                                             label="exact solution, linear model")
        self.turning_dots, = self.axes.plot([], [], ".", color=style["color"], markersize=3,
                                            label="turning points")
        self.release_line, = self.axes.plot([], [], color="grey", linewidth=1.2, label="release direction")
        self.expected_line, = self.axes.plot([], [], color="#e377c2", linewidth=2.5,
                                             label="expected swing plane now (ψ₀ − ω sin φ·t)")
        self.bob, = self.axes.plot([], [], "o", color=style["color"], markersize=8, markeredgecolor="black")
        self.axes.set_aspect("equal", adjustable="box")
        self.axes.set_xlabel("East (m)")
        self.axes.set_ylabel("North (m)")
        self.axes.grid(True, alpha=0.3)
        self.axes.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
        self.clock = self.axes.text(0.02, 0.02, "", transform=self.axes.transAxes, fontsize=9)
        self.readout = figure.text(axes_rect[0] + axes_rect[2] + 0.02, axes_rect[1], "", fontsize=9,
                                   family="monospace", va="bottom")
        self.result: SimulationResult | None = None

    def update(self, settings: SimulationSettings) -> None:
        """Recompute and redraw; parameters the model refuses show as a message and leave the plot empty."""
        self.settings = settings
        try:
            self.result = simulate(settings)
        except ValueError as error:
            self.result = None
            for line in (self.numeric_line, self.analytic_line, self.turning_dots, self.expected_line,
                         self.release_line, self.bob):
                line.set_data([], [])
            self.clock.set_text("")
            self.readout.set_text(f"cannot simulate: {error}")
            return
        self.show_until(len(self.result.t_s) - 1)
        self.readout.set_text(readout_text(self.result))
        reach = np.hypot(self.result.numeric[:, 0], self.result.numeric[:, 1])
        radius = 1.1 * max(settings.amplitude_m, float(np.nanmax(reach)) if np.isfinite(reach).any() else 0.0)
        self.axes.set_xlim(-radius, radius)
        self.axes.set_ylim(-radius, radius)
        self.axes.set_title(f"Seen from above: L = {settings.length_m:g} m, A = {settings.amplitude_m:g} m, "
                            f"φ = {settings.latitude_deg:g}°, ω = {settings.earth_rate_factor:g} Ω_E")

    def show_until(self, index: int) -> None:
        """Draw the paths up to output index ``index`` and the expected swing plane at that time."""
        result = self.result
        assert result is not None
        stop = index + 1
        self.numeric_line.set_data(*map_view(result.numeric[:stop, 0], result.numeric[:stop, 1]))
        self.analytic_line.set_data(*map_view(result.analytic[:stop, 0], result.analytic[:stop, 1]))
        shown = result.turning_points[result.turning_points[:, 0] <= result.t_s[index]]
        self.turning_dots.set_data(*map_view(shown[:, 1], shown[:, 2]))
        params = result.settings.params()
        amplitude = params.amplitude_m
        release = math.radians(params.release_azimuth_deg)
        expected = release + result.expected_rate_rad_s * result.t_s[index]
        ends = np.array([-1.0, 1.0]) * amplitude
        self.release_line.set_data(*map_view(ends * math.cos(release), ends * math.sin(release)))
        self.expected_line.set_data(*map_view(ends * math.cos(expected), ends * math.sin(expected)))
        self.bob.set_data(*map_view(result.numeric[index:stop, 0], result.numeric[index:stop, 1]))
        self.clock.set_text(f"t = {result.t_s[index] / 3600.0:.2f} h")


SLIDERS = (
    # attribute, label, minimum, maximum
    ("earth_rate_factor", "Earth's rate (× Ω_E)", 0.0, 100.0),
    ("latitude_deg", "latitude φ (°)", -90.0, 90.0),
    ("length_m", "length L (m)", 1.0, 100.0),
    ("amplitude_m", "amplitude A (m)", 0.05, 10.0),
)


class InteractiveSimulation:
    """A figure with the view and one slider per entry of ``SLIDERS``; moving a slider recomputes."""

    def __init__(self, figure: Figure, settings: SimulationSettings):
        from matplotlib.widgets import Slider

        self.view = SimulationView(figure, settings, (0.07, 0.36, 0.5, 0.58))
        self.sliders = {}
        for row, (attribute, label, low, high) in enumerate(SLIDERS):
            slider_axes = figure.add_axes((0.2, 0.22 - 0.05 * row, 0.5, 0.03))
            slider = Slider(slider_axes, label, low, high, valinit=getattr(settings, attribute))
            slider.on_changed(lambda value, name=attribute: self._changed(name, value))
            self.sliders[attribute] = slider
        self.view.update(settings)

    def _changed(self, attribute: str, value: float) -> None:
        self.view.update(replace(self.view.settings, **{attribute: float(value)}))
        self.view.figure.canvas.draw_idle()


def save_animation(settings: SimulationSettings, path: Path, frames: int, fps: int) -> Path:
    """Write the view as an animation to ``path`` (.gif with Pillow, .mp4 with ffmpeg), drawing with Agg."""
    from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter, writers
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    suffix = path.suffix.lower()
    if suffix == ".mp4" and not writers.is_available("ffmpeg"):
        raise InputError("writing .mp4 needs ffmpeg, which is not installed (e.g. `apt-get install ffmpeg`); "
                         "save a .gif instead")
    writer = PillowWriter(fps=fps) if suffix == ".gif" else FFMpegWriter(fps=fps)
    figure = Figure(figsize=(10, 6))
    FigureCanvasAgg(figure)
    view = SimulationView(figure, settings, (0.08, 0.1, 0.5, 0.82))
    view.update(settings)
    if view.result is None:
        raise InputError(view.readout.get_text())
    last = len(view.result.t_s) - 1
    indices = np.unique(np.linspace(0, last, max(2, frames)).round().astype(int))
    animation = FuncAnimation(figure, lambda i: view.show_until(int(i)), frames=indices, blit=False)
    path.parent.mkdir(parents=True, exist_ok=True)
    animation.save(path, writer=writer, dpi=ANIMATION_DPI)
    return path


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
    figure = plt.figure(figsize=(12, 8))
    simulation = InteractiveSimulation(figure, settings)  # holds the sliders while the window is open
    plt.show()
    return 0 if simulation.view.result is not None else 1
