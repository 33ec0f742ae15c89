"""``gbs``: Gragg-Bulirsch-Stoer extrapolation with order and step-size control (ODEX), compiled.

The explicit midpoint rule with Gragg's smoothing step over the harmonic sequence 2, 4, 6, …, extrapolated by
Aitken-Neville, with Hairer and Wanner's order and step-size control (Hairer, Nørsett & Wanner, Solving ODEs I,
2nd ed., §II.9; their code ODEX; Deuflhard, Numer. Math. 41, 399 (1983) for the work-per-step order choice):
``integrators.extrapolation_driver``. Variable order 4-16 (line k of the table has order 2k; k from 2 to 8,
plus line 9 to test convergence), chosen per step to minimise the evaluations per unit step.

Tolerance mapping: rtol = tol and atol = tol × (R, R, kR, kR) (``integrators.adaptive``), ODEX's mixed
componentwise error test.

Output grid: the steps land on every output time (ODEX's dense output needs another sequence; integrators/README.md
"Gragg-Bulirsch-Stoer extrapolation"). No turning points are streamed (the verdicts take them from the grid).

Stability: explicit; the step control keeps the steps accuracy-limited at every tolerance used here.
"""

from __future__ import annotations

from typing import ClassVar, cast

import numpy as np

from foucault_bench.integrators.adaptive import AdaptiveIntegrator, absolute_tolerance, step_budget
from foucault_bench.integrators.base import COST_COMPILED, STATUS_FAILED, Problem, Solution
from foucault_bench.integrators.extrapolation_driver import CODE_OK, MESSAGES, STATE_SIZE, compiled_driver
from foucault_bench.integrators.registry import register

INITIAL_STEP_KH = 0.1
"""The first step in units of 1/k (ODEX: "H = 1/(norm of f'), usually 1e-1 or 1e-3, is good")."""


@register
class Gbs(AdaptiveIntegrator):
    """ODEX's extrapolation code on the model's compiled acceleration.

    Options: ``max_steps`` caps the step attempts of one run (default ``integrators.adaptive.step_budget``);
    reaching it gives a ``failed`` solution."""

    name: ClassVar[str] = "gbs"
    family: ClassVar[str] = "extrapolation"
    order: ClassVar[int | None] = None
    cost_basis: ClassVar[str] = COST_COMPILED
    silence_native_output: ClassVar[bool] = False
    reference: ClassVar[str] = ("Hairer, Nørsett & Wanner, Solving ODEs I, §II.9 (ODEX); Gragg, SIAM J. Numer. Anal. 2, "
                                "384 (1965); Bulirsch & Stoer, Numer. Math. 8, 1 (1966); Deuflhard, Numer. Math. 41, "
                                "399 (1983)")

    def __init__(self, max_steps: int | None = None) -> None:
        if max_steps is not None and max_steps < 1:
            raise ValueError(f"max_steps must be a positive number of steps, got {max_steps!r}")
        self.max_steps = max_steps

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        params = problem.params
        limit = self.max_steps or step_budget(params, problem.t_end_s)
        out = np.full((problem.t_out.size, STATE_SIZE), np.nan)
        h_initial = INITIAL_STEP_KH / params.pendulum_frequency_rad_s
        code, t_reached, nfev, steps, rejected = compiled_driver(problem.model)(
            problem.initial_state, problem.parameter_vector, problem.t_out, float(cast(float, tol)),
            absolute_tolerance(params, cast(float, tol)), h_initial, limit, out)
        solution = Solution(t=problem.t_out, y=out, nfev=int(nfev), njev=0, steps=int(steps),
                            rejected_steps=int(rejected))
        if code != CODE_OK:
            solution.status = STATUS_FAILED
            solution.message = MESSAGES[code].format(limit=limit, t=float(t_reached))
        return solution

