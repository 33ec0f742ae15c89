"""What the compiled adaptive drivers that step onto the output times share (``gbs``: integrators/
extrapolation_driver.py; ``fine_rkn5``: integrators/rkn.py): the cut of a step at the next output time, the
attempt check, the failure codes and the integrator base that runs a driver and fills the solution.

**Stepping onto the output times.** A step that would pass the next output time, or end within ``CUT_SLACK`` − 1
of a step before it (a sliver step), is cut to end on it, as ODEX and DOPRI5 treat the last step of an
integration (Hairer, Nørsett & Wanner, Solving ODEs I, §II.9 and the codes odex.f and dopri5.f); the state written
there is the method's own step result. A step below 10 ulp of t, or more attempts than the step budget, fails
the run (its remaining rows stay NaN).
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Callable, ClassVar, cast

import numpy as np

from foucault_bench.integrators.adaptive import AdaptiveIntegrator, absolute_tolerance, step_budget
from foucault_bench.integrators.base import COST_COMPILED, STATUS_FAILED, Problem, Solution
from foucault_bench.models import Model
from foucault_bench.models.jit import jit

STATE_SIZE = 4
CUT_SLACK = 1.01
"""A step ending within 1 % of a step before an output time is stretched to end on it."""

CODE_OK, CODE_TOO_SMALL_STEP, CODE_STEP_LIMIT = 0, 1, 2
MESSAGES = {
    CODE_TOO_SMALL_STEP: "step size below 10 ulp of t at t = {t!r} s",
    CODE_STEP_LIMIT: "step limit of {limit} step attempts reached at t = {t!r} s",
}


@jit(inline="always")
def cut_step(t, h, target):
    """(h, last): the step shortened to end at ``target`` when it would pass it or end just before it."""
    h = min(h, target - t)
    last = t + CUT_SLACK * h - target > 0.0
    return (target - t if last else h), last


@jit(inline="always")
def attempt_code(t, h, attempts, max_steps):
    """``CODE_TOO_SMALL_STEP`` for a step below 10 ulp of t, ``CODE_STEP_LIMIT`` past the budget, else ``CODE_OK``."""
    if h < 10.0 * (np.nextafter(t, np.inf) - t):
        return CODE_TOO_SMALL_STEP
    if attempts > max_steps:
        return CODE_STEP_LIMIT
    return CODE_OK


@jit(inline="always")
def write_initial_rows(y, t_out, out):
    """Write the initial state on the output times at t ≤ 0; returns the index of the first output time ahead."""
    next_out = 0
    while next_out < t_out.shape[0] and t_out[next_out] <= 0.0:
        out[next_out, :] = y
        next_out += 1
    return next_out


class GridSteppingIntegrator(AdaptiveIntegrator):
    """Base of the compiled adaptive integrators whose driver steps onto the output times: a subclass gives
    ``compiled_driver(model)``, a driver ``(y0, p, t_out, rtol, atol, h_initial, max_steps, out) -> (code, t,
    nfev, accepted, rejected)``.

    Options: ``max_steps`` caps the step attempts of one run (default ``integrators.adaptive.step_budget``);
    reaching it gives a ``failed`` solution."""

    cost_basis: ClassVar[str] = COST_COMPILED
    silence_native_output: ClassVar[bool] = False
    initial_step_kh: ClassVar[float] = 0.1
    """The first step in units of 1/k (ODEX: "H = 1/(norm of f'), usually 1e-1 or 1e-3, is good"; the
    controllers adapt it within a few steps)."""

    def __init__(self, max_steps: int | None = None) -> None:
        if max_steps is not None and max_steps < 1:
            raise ValueError(f"max_steps must be a positive number of steps, got {max_steps!r}")
        self.max_steps = max_steps

    @abstractmethod
    def compiled_driver(self, model: Model) -> Callable:
        """The compiled driver for ``model``."""

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        params = problem.params
        limit = self.max_steps or step_budget(params, problem.t_end_s)
        out = np.full((problem.t_out.size, STATE_SIZE), np.nan)
        code, t_reached, nfev, steps, rejected = self.compiled_driver(problem.model)(
            problem.initial_state, problem.parameter_vector, problem.t_out, float(cast(float, tol)),
            absolute_tolerance(params, cast(float, tol)), self.initial_step_kh / params.pendulum_frequency_rad_s,
            limit, out)
        solution = Solution(t=problem.t_out, y=out, nfev=int(nfev), njev=0, steps=int(steps),
                            rejected_steps=int(rejected))
        if code != CODE_OK:
            solution.status = STATUS_FAILED
            solution.message = MESSAGES[code].format(limit=limit, t=float(t_reached))
        return solution
