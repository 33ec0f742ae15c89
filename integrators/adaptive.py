"""What the adaptive (tolerance-driven) integrators share: the tolerance mapping, the step budget and the
turning points.

**Tolerance mapping.** The suite gives every adaptive integrator one number, ``tol``. Each library receives it
so that the local error it accepts per step is about ``tol`` times the scale of the swing:

* characteristic scale of each state component (``state_scale``): R for x and y, k·R for ẋ and ẏ, where
  k = √(g/L) and R = √(A² + |v₀|²/k²) is the amplitude of the linear oscillator with the release energy
  (R = A for a release from rest);
* CVODE and scipy (mixed error tests |e_i| ≤ rtol·|y_i| + atol_i): ``rtol = tol`` and ``atol_i = tol × scale_i``
  (``absolute_tolerance``). The absolute part matters: x, y, ẋ and ẏ all cross zero on every swing;
* heyoka (one tolerance ε, absolute error control while every |y_i| < 1, relative to the largest |y_i| once one
  exceeds 1; heyoka docs, "Customising the adaptive integrator"): ``ε = tol × min(1, max_i scale_i)``
  (``heyoka_tolerance``), which again bounds the error by about tol × scale in SI units.

**Step budget.** ``step_budget`` allows ``MAX_STEPS_PER_SWING_PERIOD`` steps per small-swing period (and at
least ``MIN_STEP_BUDGET``), far above what any tolerance down to 1e-14 needs on these models (a few hundred
steps per period), so that only a runaway integration (a singularity or an impossible accuracy request) hits it.

**Turning points.** The maxima of the radius are the roots of r·ṙ = xẋ + yẏ where it crosses from + to −
(integrators/README.md "Measuring the precession rate"), found by each library's event mechanism. A release from rest
makes r·ṙ = 0 at t = 0, which heyoka and scipy report as a root and CVODE does not; ``turning_points`` drops
every event closer to t = 0 than ``RELEASE_EVENT_WINDOW_PERIODS`` small-swing periods, so all integrators
return the same set as the fixed-step streams (t > 0).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from foucault_bench.integrators.base import Integrator, Problem
from foucault_bench.models import PendulumParameters

MAX_STEPS_PER_SWING_PERIOD = 100_000
"""Step budget per small-swing period 2π/k (see module docstring)."""

MIN_STEP_BUDGET = 500
"""Smallest step budget (SUNDIALS' own default per output interval)."""

RELEASE_EVENT_WINDOW_PERIODS = 1.0e-6
"""Events earlier than this fraction of a small-swing period are the release point, not a turning point."""


class AdaptiveIntegrator(Integrator):
    """Base of the library-driven adaptive integrators: driven by ``tol``, no fixed stage count."""

    adaptive: ClassVar[bool] = True
    stages: ClassVar[int | None] = None


def release_scale_m(params: PendulumParameters) -> float:
    """R = √(A² + |v₀|²/k²) (m): the amplitude of the linear oscillator with the release energy."""
    k = params.pendulum_frequency_rad_s
    vx, vy = params.release_velocity_m_s
    return math.sqrt(params.amplitude_m**2 + (vx * vx + vy * vy) / (k * k))


def state_scale(params: PendulumParameters) -> np.ndarray:
    """Characteristic scale of (x, y, ẋ, ẏ): (R, R, kR, kR) in m and m/s."""
    radius = release_scale_m(params)
    speed = params.pendulum_frequency_rad_s * radius
    return np.array([radius, radius, speed, speed])


def absolute_tolerance(params: PendulumParameters, tol: float) -> np.ndarray:
    """atol_i = tol × scale_i (m, m, m/s, m/s), used with rtol = tol by CVODE and scipy."""
    return tol * state_scale(params)


def heyoka_tolerance(params: PendulumParameters, tol: float) -> float:
    """heyoka's single ε = tol × min(1, max_i scale_i) (see module docstring); max_i scale_i = max(R, kR)."""
    radius = release_scale_m(params)
    return tol * min(1.0, max(radius, params.pendulum_frequency_rad_s * radius))


def step_budget(params: PendulumParameters, span_s: float) -> int:
    """Most steps allowed over ``span_s`` seconds: ``MAX_STEPS_PER_SWING_PERIOD`` per small-swing period."""
    periods = span_s / params.small_swing_period_s
    return max(MIN_STEP_BUDGET, math.ceil(MAX_STEPS_PER_SWING_PERIOD * periods))


def turning_points(problem: Problem, t_s: np.ndarray, x_m: np.ndarray, y_m: np.ndarray) -> np.ndarray:
    """The (n, 3) array of (t, x, y) of the radius maxima from a library's event times and positions, without
    the release point (events within ``RELEASE_EVENT_WINDOW_PERIODS`` periods of t = 0), sorted by time."""
    rows = np.column_stack([np.asarray(t_s, dtype=np.float64), np.asarray(x_m, dtype=np.float64),
                            np.asarray(y_m, dtype=np.float64)]).reshape(-1, 3)
    window_s = RELEASE_EVENT_WINDOW_PERIODS * problem.params.small_swing_period_s
    rows = rows[rows[:, 0] > window_s]
    return rows[np.argsort(rows[:, 0], kind="stable")]
