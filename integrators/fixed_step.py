"""Compiled fixed-step machinery shared by every fixed-step scheme.

A scheme supplies one numba step function ``step(x, y, vx, vy, h, p) -> (x, y, vx, vy)`` built from the model
(``FixedStepIntegrator.make_step``; ``p`` arrives as a tuple of floats in the layout of the parameter vector).
This module wraps it in one compiled loop that

* runs n steps with scalars only (no allocation per step), so 10⁸ steps need memory for the output grid only;
* writes the state every ``stride`` steps into a preallocated output array (the output grid);
* streams the verdict ingredients when ``monitor`` is on: the max relative energy error, the least-squares
  drift slope of the relative energy error (Welford's online covariance, stable over 10⁸ samples), and
  the turning points (maxima of the radius: r·ṙ changes sign from + to −, located on the cubic Hermite
  interpolant of the step; integrators/README.md "Measuring the precession rate");
* stops at the first non-finite state or when the bob leaves a bound (diverged);
* adds a scheme's step to the state with compensated (Kahan) summation when the scheme supplies its step as an
  increment (``FixedStepIntegrator.make_increment``): the rounding error of each addition is carried in a
  compensation term and added back in the next step, so the state update contributes round-off like ε√n
  instead of up to εn after n steps (Kahan, Comm. ACM 8, 40 (1965); Hairer, McLachlan & Razakarivony,
  BIT 48, 231 (2008), §3).

``nfev`` is counted, not declared: the step's right-hand-side evaluations per step are counted once per model by a
compiled run of the same step on a counting copy of the model (``integrators.counting``), and a run's ``nfev`` is
that count times its steps, for every scheme that declares a fixed ``stages`` (``None``: an iterative scheme whose
count varies from step to step reports no ``nfev``). ``foucault-bench selftest`` compares the count with the
declared ``stages`` (``bench.gate.conformance``).
"""

from __future__ import annotations

import functools
import math
from abc import abstractmethod
from typing import Callable, ClassVar, cast

import numpy as np
from numba.np.unsafe.ndarray import to_fixed_tuple

from foucault_bench.integrators.base import COST_COMPILED, STATUS_DIVERGED, Integrator, Problem, Solution, StreamedMetrics
from foucault_bench.integrators.counting import evaluations_per_step
from foucault_bench.models import Model, PendulumParameters
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import PARAMETER_COUNT

DIVERGENCE_RADIUS_FACTOR = 1.0e3
"""A run is declared diverged when the bob is farther than this many string lengths from the vertical."""

STATUS_CODE_DIVERGED = 1

COUNTED_STEPS = 8
"""Steps over which ``FixedStepIntegrator.evaluations_per_step`` counts (any number shows a fixed count)."""

COMPILE_PARAMETERS = PendulumParameters(length_m=1.0, latitude_deg=45.0, amplitude_m=0.1)
"""The setting of the one-step compile run and of the counted steps (kh = 0.1 from the release at rest)."""


@jit
def _hermite(theta, h, p0, v0, p1, v1):
    """Cubic Hermite interpolant on one step (θ ∈ [0, 1]) and its first two θ-derivatives."""
    t2 = theta * theta
    t3 = t2 * theta
    value = (2 * t3 - 3 * t2 + 1) * p0 + (t3 - 2 * t2 + theta) * h * v0 + (-2 * t3 + 3 * t2) * p1 + (t3 - t2) * h * v1
    slope = (6 * t2 - 6 * theta) * p0 + (3 * t2 - 4 * theta + 1) * h * v0 + (6 * theta - 6 * t2) * p1 + (3 * t2 - 2 * theta) * h * v1
    curve = (12 * theta - 6) * (p0 - p1) + (6 * theta - 4) * h * v0 + (6 * theta - 2) * h * v1
    return value, slope, curve


@jit
def _turning_point(x0, y0, vx0, vy0, x1, y1, vx1, vy1, h, radial0, radial1):
    """Maximum of the radius inside one step: root of s(θ) = P(θ)·P'(θ) for the cubic Hermite interpolant P,
    from the linear guess θ = s₀/(s₀ − s₁) refined by three Newton steps (Hairer, Nørsett & Wanner,
    Solving ODEs I, §II.6 on dense output and event location). Returns (θ, x, y)."""
    theta = radial0 / (radial0 - radial1)
    for _ in range(3):
        px, sx, cx = _hermite(theta, h, x0, vx0, x1, vx1)
        py, sy, cy = _hermite(theta, h, y0, vy0, y1, vy1)
        derivative = sx * sx + sy * sy + px * cx + py * cy
        if derivative == 0.0:
            break
        theta = min(1.0, max(0.0, theta - (px * sx + py * sy) / derivative))
    px, _, _ = _hermite(theta, h, x0, vx0, x1, vx1)
    py, _, _ = _hermite(theta, h, y0, vy0, y1, vy1)
    return theta, px, py


@jit(inline="always")
def compensated_add(total, increment, compensation):
    """``total`` + ``increment`` with compensated summation: (new total, new compensation). The compensation
    holds what the previous additions rounded away; it is added to the increment first, and what this addition
    rounds away becomes the new compensation (Kahan 1965, in the form of Hairer, McLachlan & Razakarivony,
    BIT 48, 231 (2008), Algorithm 1)."""
    compensation += increment
    new_total = total + compensation
    return new_total, compensation + (total - new_total)


@jit(inline="always")
def _parameters(h, p):
    """The setup of a scheme without one: its step takes the parameters themselves."""
    return p


def with_setup(setup: Callable, step: Callable) -> Callable:
    """The step ``(x, y, vx, vy, h, p) -> new state`` of a scheme whose step takes the constants ``setup(h, p)``
    computes in place of p (``FixedStepIntegrator.make_setup_step``): here computed at every call, which a
    one-step analysis can afford and a loop cannot."""

    @jit(inline="always")
    def standalone(x, y, vx, vy, h, p):
        return step(x, y, vx, vy, h, setup(h, p))

    return standalone


def state_plus(increment: Callable) -> Callable:
    """The step ``(x, y, vx, vy, h, p) -> new state`` of a scheme given by its ``increment`` (plain sums)."""

    @jit(inline="always")
    def step(x, y, vx, vy, h, p):
        dx, dy, dvx, dvy = increment(x, y, vx, vy, h, p)
        return x + dx, y + dy, vx + dvx, vy + dvy

    return step


def _advance(step: Callable, increment: Callable | None) -> Callable:
    """``(x, y, vx, vy, c, h, p) -> (x, y, vx, vy, c)``: one step, with the compensation tuple ``c`` of the
    compensated sum when the scheme has an ``increment`` (``c`` stays zero, and is compiled away, otherwise)."""
    if increment is None:

        @jit(inline="always")
        def plain(x, y, vx, vy, c, h, p):
            xn, yn, vxn, vyn = step(x, y, vx, vy, h, p)
            return xn, yn, vxn, vyn, c

        return plain

    @jit(inline="always")
    def compensated(x, y, vx, vy, c, h, p):
        dx, dy, dvx, dvy = increment(x, y, vx, vy, h, p)
        cx, cy, cvx, cvy = c
        xn, cx = compensated_add(x, dx, cx)
        yn, cy = compensated_add(y, dy, cy)
        vxn, cvx = compensated_add(vx, dvx, cvx)
        vyn, cvy = compensated_add(vy, dvy, cvy)
        return xn, yn, vxn, vyn, (cx, cy, cvx, cvy)

    return compensated


def build_kernel(step: Callable, energy: Callable, increment: Callable | None = None,
                 setup: Callable | None = None) -> Callable:
    """Compile the fixed-step loop around ``step`` with the model's ``energy`` for streamed metrics; with the
    scheme's ``increment`` the state is advanced by it with compensated summation (module docstring); with the
    scheme's ``setup`` (``FixedStepIntegrator.make_setup_step``) the step and the increment take ``setup(h, p)``,
    computed once before the first step, in place of p."""
    advance = _advance(step, increment)
    prepare = _parameters if setup is None else setup

    @jit
    def kernel(state0, parameter_vector, h, n_steps, stride, out, monitor, turning, radius_bound):
        # n_steps: a multiple of stride (out has n_steps // stride + 1 rows)
        # The parameters as a tuple of scalars: unlike array elements they cannot alias the output arrays
        # written in the loop, so LLVM hoists what the step computes from p and h alone out of the loop.
        p = to_fixed_tuple(parameter_vector, PARAMETER_COUNT)
        constants = prepare(h, p)
        x = state0[0]
        y = state0[1]
        vx = state0[2]
        vy = state0[3]
        out[0, 0] = x
        out[0, 1] = y
        out[0, 2] = vx
        out[0, 3] = vy
        energy0 = energy(x, y, vx, vy, p)
        # the swing's energy above the bob at rest at the bottom (bench.verdicts.columns.energy_scale, the table's unit)
        energy_scale = energy0 - energy(0.0, 0.0, 0.0, 0.0, p)
        if not energy_scale > 0.0:
            energy_scale = abs(energy0) if energy0 != 0.0 else 1.0
        max_rel = 0.0
        # Welford accumulators for the slope of relative energy error against time.
        count = 0.0
        mean_t = 0.0
        mean_e = 0.0
        co_te = 0.0
        var_t = 0.0
        radial = x * vx + y * vy
        n_turning = 0
        bound2 = radius_bound * radius_bound
        status = 0
        steps_done = 0
        compensation = (0.0, 0.0, 0.0, 0.0)
        # one output row per ``stride`` steps: two nested loops, no modulo per step (as a C programmer writes it)
        for row in range(1, n_steps // stride + 1):
            for _ in range(stride):
                xn, yn, vxn, vyn, compensation = advance(x, y, vx, vy, compensation, h, constants)
                r2 = xn * xn + yn * yn
                if not (r2 <= bound2) or not (abs(vxn) + abs(vyn) < 1.0e300):
                    status = 1
                    break
                steps_done += 1
                if monitor:
                    t = steps_done * h
                    rel = (energy(xn, yn, vxn, vyn, p) - energy0) / energy_scale
                    if abs(rel) > max_rel:
                        max_rel = abs(rel)
                    count += 1.0
                    dt = t - mean_t
                    mean_t += dt / count
                    mean_e += (rel - mean_e) / count
                    co_te += dt * (rel - mean_e)
                    var_t += dt * (t - mean_t)
                    radial_new = xn * vxn + yn * vyn
                    if radial > 0.0 and radial_new <= 0.0 and n_turning < turning.shape[0]:
                        theta, tx, ty = _turning_point(x, y, vx, vy, xn, yn, vxn, vyn, h, radial, radial_new)
                        turning[n_turning, 0] = (steps_done - 1 + theta) * h
                        turning[n_turning, 1] = tx
                        turning[n_turning, 2] = ty
                        n_turning += 1
                    radial = radial_new
                x = xn
                y = yn
                vx = vxn
                vy = vyn
            if status:
                break
            out[row, 0] = x
            out[row, 1] = y
            out[row, 2] = vx
            out[row, 3] = vy
        slope = co_te / var_t if var_t > 0.0 else 0.0
        return status, steps_done, n_turning, max_rel, slope

    return kernel


def uniform_output_stride(t_out: np.ndarray, step_s: float) -> tuple[int, float]:
    """Steps per output interval and the effective step (s) for a uniform grid starting at 0.

    The step is shortened (never lengthened) so that each output interval holds a whole number of steps;
    the effective step is reported with the solution.
    """
    spacing = t_out[1] - t_out[0]
    if t_out[0] != 0.0 or not np.allclose(np.diff(t_out), spacing, rtol=1e-9, atol=0.0):
        raise ValueError("fixed-step integrators need a uniform output grid starting at t = 0")
    stride = max(1, math.ceil(spacing / step_s * (1.0 - 1e-12)))
    return stride, spacing / stride


class FixedStepIntegrator(Integrator):
    """Base of the compiled fixed-step schemes: a subclass only builds its numba step function."""

    adaptive: ClassVar[bool] = False
    cost_basis: ClassVar[str] = COST_COMPILED
    streams_step_metrics: ClassVar[bool] = True  # the per-step energy error, which the grid cannot give

    @abstractmethod
    def make_step(self, model: Model) -> Callable:
        """A numba function ``(x, y, vx, vy, h, p) -> (x, y, vx, vy)`` advancing the model's state by h (``p``:
        the parameter vector, passed by the loop as a tuple of floats; compile it with ``models.jit.jit``)."""

    def make_setup_step(self, model: Model) -> tuple[Callable, Callable] | None:
        """For a scheme whose step needs constants computed from h and the parameters alone (a composition's
        rotations and sub-step sizes): ``(setup, step)``, ``setup(h, p)`` a numba function the loop calls once
        per run and ``step(x, y, vx, vy, h, constants)`` taking its result in place of p (``make_step`` is then
        ``with_setup(setup, step)``). ``None`` (the default): the loop runs ``make_step``'s step on p itself."""
        return None

    def make_increment(self, model: Model) -> Callable | None:
        """For a scheme whose step is best written as an increment: a numba function ``(x, y, vx, vy, h, p) ->
        (dx, dy, dvx, dvy)``, which the loop adds to the state with compensated summation (``None``: the loop
        takes the new state from ``make_step``; such a scheme defines ``make_step`` as ``state_plus`` of it)."""
        return None

    @functools.lru_cache(maxsize=None)
    def compiled_step(self, model: Model) -> Callable:
        """``make_step(model)``, built once per model (callable from Python too, e.g. to analyse one step)."""
        return self.make_step(model)

    @functools.lru_cache(maxsize=None)
    def loop_step(self, model: Model) -> tuple[Callable, Callable | None]:
        """``(step, setup)`` as the loop runs them, built once per model: ``make_setup_step``'s pair, or
        ``compiled_step`` and no setup."""
        prepared = self.make_setup_step(model)
        return (self.compiled_step(model), None) if prepared is None else (prepared[1], prepared[0])

    @functools.lru_cache(maxsize=None)
    def kernel(self, model: Model) -> Callable:
        """The compiled loop for this scheme and model (compiled on first use, cached on disk by numba)."""
        step, setup = self.loop_step(model)
        return build_kernel(step, model.numba_energy, self.make_increment(model), setup)

    @functools.lru_cache(maxsize=None)
    def evaluations_per_step(self, model: Model) -> float:
        """Right-hand-side evaluations per step, counted over ``COUNTED_STEPS`` steps (``integrators.counting``)."""
        h = 0.1 / COMPILE_PARAMETERS.pendulum_frequency_rad_s
        return evaluations_per_step(self.make_step, model, np.array([COMPILE_PARAMETERS.amplitude_m, 0.0, 0.0, 0.0]),
                                    COMPILE_PARAMETERS.parameter_vector(), h, COUNTED_STEPS)

    def counted_nfev(self, model: Model, steps: int) -> int | None:
        """``steps`` × the counted evaluations per step, for a scheme that declares a fixed ``stages``; ``None``
        for one that does not, or whose count is not a whole number per step."""
        per_step = self.evaluations_per_step(model)
        return int(per_step) * steps if self.stages is not None and per_step.is_integer() else None

    def compile(self, model: Model) -> None:
        """Compile (or load from numba's cache) the loop for ``model`` with a one-step run, and count its step's
        evaluations."""
        p = COMPILE_PARAMETERS.parameter_vector()
        out = np.empty((2, 4))
        self.kernel(model)(np.array([0.1, 0.0, 0.0, 0.0]), p, 0.1, 1, 1, out, True, np.empty((1, 3)), 1.0e3)
        self.evaluations_per_step(model)

    def validate_problem(self, problem: Problem, *, step_s: float | None) -> None:
        uniform_output_stride(problem.t_out, cast(float, step_s))  # validate_setting checked it first

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        stride, h, n_steps = self.steps_for(problem, cast(float, step_s))
        out = np.full((problem.t_out.size, 4), np.nan)
        turning = np.empty((self.turning_capacity(problem) if monitor else 0, 3))
        status, steps_done, n_turning, max_rel, slope = self.kernel(problem.model)(
            problem.initial_state, problem.parameter_vector, h, n_steps, stride, out, monitor, turning,
            self.radius_bound_m(problem),
        )
        return self.kernel_solution(problem, out, h, n_steps, int(status), int(steps_done),
                                    turning[:n_turning] if monitor else None, max_rel, slope)

    @staticmethod
    def steps_for(problem: Problem, step_s: float) -> tuple[int, float, int]:
        """Steps per output interval, the effective step (s) and the total number of steps of a run."""
        stride, h = uniform_output_stride(problem.t_out, step_s)
        return stride, h, stride * (problem.t_out.size - 1)

    @staticmethod
    def turning_capacity(problem: Problem) -> int:
        """Rows of the turning-point buffer: 2.2 per small-swing period (a swing has 2) and 16 more."""
        return int(2.2 * problem.t_end_s / problem.params.small_swing_period_s) + 16

    @staticmethod
    def radius_bound_m(problem: Problem) -> float:
        """The distance from the vertical beyond which a run is declared diverged."""
        return DIVERGENCE_RADIUS_FACTOR * problem.params.length_m

    def kernel_solution(self, problem: Problem, out: np.ndarray, h: float, n_steps: int, status: int,
                        steps_done: int, turning: np.ndarray | None, max_rel: float, slope: float) -> Solution:
        """The ``Solution`` of one kernel run from what the kernel wrote and returned (``turning``: the rows
        found, ``None`` without ``monitor``)."""
        solution = Solution(t=problem.t_out, y=out, steps=steps_done, step_size_s=h,
                            nfev=self.counted_nfev(problem.model, steps_done))
        if status == STATUS_CODE_DIVERGED:
            solution.status = STATUS_DIVERGED
            solution.message = (
                f"diverged after {steps_done} of {n_steps} steps (t = {steps_done * h:.6g} s): state non-finite "
                f"or farther than {DIVERGENCE_RADIUS_FACTOR:g} L from the vertical"
            )
        if turning is not None:
            solution.streamed = StreamedMetrics(
                energy_max_rel_error=max_rel, energy_drift_per_s=slope, turning_points=turning.copy()
            )
        return solution
