"""What ``foucault-bench simulate`` computes: the settings' model integrated by their integrator on an output grid,
the exact linear solution on the same grid (``models.analytic.linear_exact``), and the precession rate measured
on the numeric solution's turning points (``bench.problems.turning_points.turning_points_from_grid`` and
``precession_rate``, the procedure of the results table) beside the textbook −ω sin φ and, for the spherical
model, Airy's finite-amplitude rate. ``reports.simulate`` draws the result."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from foucault_bench.bench.problems.turning_points import grid_accelerations, precession_rate, turning_points_from_grid
from foucault_bench.bench.simulation_settings import SimulationSettings
from foucault_bench.integrators import STATUS_OK, Problem, get_integrator
from foucault_bench.models import PendulumParameters, get_model
from foucault_bench.models.analytic import linear_exact

OUTPUT_POINTS_PER_PERIOD = 16
"""Output grid density: 16 points per small-swing period (turning points need fewer than a quarter period
between samples, ``bench.verdicts``; the extra density draws the swing smoothly)."""
MAX_OUTPUT_POINTS = 400_000
"""Largest output grid the command accepts (the view redraws it on every slider move)."""


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
    airy_rate_rad_s: float | None = None
    """Airy's finite-amplitude rate for the spherical model (``PendulumParameters.airy_precession_rate_rad_s``),
    ``None`` for the planar models."""

    @property
    def plane_rate_rad_s(self) -> float:
        """The rate the expected swing plane turns at: Airy's for the spherical model, −ω sin φ otherwise."""
        return self.expected_rate_rad_s if self.airy_rate_rad_s is None else self.airy_rate_rad_s


def output_intervals(settings: SimulationSettings, params: PendulumParameters) -> int:
    """Intervals of the output grid over ``settings.hours``: ``OUTPUT_POINTS_PER_PERIOD`` per small-swing
    period of ``params`` (``settings.params()``), at least one."""
    return max(1, math.ceil(OUTPUT_POINTS_PER_PERIOD * settings.hours * 3600.0 / params.small_swing_period_s))


def simulate(settings: SimulationSettings) -> SimulationResult:
    """Integrate the settings' model with its integrator and measure the precession (``ValueError`` for
    parameters the model refuses, e.g. an amplitude not below the length)."""
    params = settings.params()
    duration = settings.hours * 3600.0
    t = np.linspace(0.0, duration, output_intervals(settings, params) + 1)
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
                            message=solution.message,
                            airy_rate_rad_s=params.airy_precession_rate_rad_s if settings.model == "spherical" else None)
