"""scipy's ``solve_ivp`` as baselines: ``scipy_dop853``, ``scipy_rk45`` and ``scipy_lsoda``.

One driver (``ScipyIvpIntegrator``) parametrised by the method name; the registered subclasses only declare
facts. Configuration (SciPy reference guide, ``scipy.integrate.solve_ivp``):

* **Tolerances.** ``rtol = tol`` and ``atol = tol × (R, R, kR, kR)``, the same mapping as CVODE
  (``integrators.adaptive``). scipy raises any rtol below 100 × machine epsilon (2.2e-14) to that value with
  a warning; the suite refuses such a ``tol`` instead (``ValueError``), so the tolerance in a table is the one
  used.
* **Right-hand side.** ``Model.numba_rhs`` (t, y, p) with ``args=(p,)``; LSODA, which switches to BDF when it
  detects stiffness, also gets ``Model.jacobian`` (heyoka's symbolic derivative of the model's source).
* **Output.** ``t_eval`` = the output grid (each method's dense output; the steps are not changed by it).
* **Turning points.** With ``monitor=True`` (the default of ``solve``), ``events`` on r·ṙ = xẋ + yẏ with
  ``direction = −1`` (radius maxima); scipy reports the release point t = 0 as a root for a release from rest,
  which ``integrators.adaptive.turning_points`` drops. The benchmark runner times ``monitor=False`` (no event
  function: the same work as every other integrator; the verdicts take the turning points from the output
  grid, ``bench.problems.turning_points``).
* **Counters.** ``nfev``, ``njev`` from the result; ``steps`` = accepted steps, counted by a subclass of the
  method's ``OdeSolver`` (``solve_ivp`` accepts a solver class as ``method``) whose ``step`` counts successful
  calls; ``rejected_steps`` is ``None`` (scipy does not report it).
* **Guards.** ``solve_ivp`` has no step limit, and scipy's LSODA wrapper loops for ever once its step size
  underflows to zero (observed here on a finite-time blow-up: t stops advancing, every step "succeeds"). The
  same subclass therefore fails a run whose time stops advancing and one that exceeds ``max_steps`` accepted
  steps (default ``integrators.adaptive.step_budget``).
* **Failures.** ``status = −1`` (e.g. "Required step size is less than spacing between numbers.", or a guard's
  message) becomes a ``failed`` solution with that message; output rows not reached are NaN.
"""

from __future__ import annotations

import functools
from typing import ClassVar, cast

import numpy as np
from scipy.integrate import DOP853, LSODA, RK45, OdeSolver, solve_ivp

from foucault_bench.integrators.adaptive import AdaptiveIntegrator, absolute_tolerance, step_budget, turning_points
from foucault_bench.integrators.base import COST_PYTHON_DRIVEN, STATUS_FAILED, Problem, Solution, StreamedMetrics
from foucault_bench.integrators.registry import register

SCIPY_MIN_RTOL = 100.0 * np.finfo(np.float64).eps
"""Smallest rtol scipy uses as given (scipy.integrate._ivp.common.validate_tol)."""


def radial_event(t: float, y: np.ndarray, p: np.ndarray) -> float:
    """r·ṙ = xẋ + yẏ (m²/s); its + → − crossings are the radius maxima."""
    return y[0] * y[2] + y[1] * y[3]


radial_event.terminal = False  # type: ignore[attr-defined]  # solve_ivp reads an event's options off the function
radial_event.direction = -1.0  # type: ignore[attr-defined]


class StepMonitor:
    """Accepted-step count and step limit, handed to the guarded solver through ``solve_ivp``'s options."""

    def __init__(self, limit: int) -> None:
        self.accepted = 0
        self.limit = limit


@functools.cache
def guarded_solver(solver_class: type[OdeSolver]) -> type[OdeSolver]:
    """A subclass of ``solver_class`` whose ``step`` counts accepted steps into the ``step_monitor`` option and
    fails the run (status ``"failed"`` with a message) when the time stops advancing or the limit is passed."""

    def __init__(self, *args, step_monitor: StepMonitor, **options):
        self.step_monitor = step_monitor
        solver_class.__init__(self, *args, **options)

    def step(self):
        t_before = self.t
        message = solver_class.step(self)
        if self.status == "failed":
            return message
        self.step_monitor.accepted += 1
        if self.t == t_before:
            self.status = "failed"
            return f"no progress: the step size fell to zero at t = {self.t!r} s"
        if self.status == "running" and self.step_monitor.accepted >= self.step_monitor.limit:
            self.status = "failed"
            return f"step limit of {self.step_monitor.limit} accepted steps reached at t = {self.t!r} s"
        return message

    return type(f"Guarded{solver_class.__name__}", (solver_class,), {"__init__": __init__, "step": step})


class ScipyIvpIntegrator(AdaptiveIntegrator):
    """``solve_ivp`` with one of its methods; subclasses set ``solver_class`` and the declared facts.

    Options: ``max_steps`` caps the accepted steps of one run (default ``integrators.adaptive.step_budget``);
    reaching it gives a ``failed`` solution.
    """

    solver_class: ClassVar[type[OdeSolver]]
    uses_jacobian: ClassVar[bool] = False
    cost_basis: ClassVar[str] = COST_PYTHON_DRIVEN  # solve_ivp's Python step loop, a Python call per evaluation

    def __init__(self, max_steps: int | None = None) -> None:
        if max_steps is not None and max_steps < 1:
            raise ValueError(f"max_steps must be a positive number of steps, got {max_steps!r}")
        self.max_steps = max_steps

    def validate_setting(self, *, step_s: float | None, tol: float | None) -> None:
        super().validate_setting(step_s=step_s, tol=tol)
        assert tol is not None  # an adaptive integrator's setting (checked just above)
        if tol < SCIPY_MIN_RTOL:
            raise ValueError(
                f"{self.name}: tolerance {tol!r} is below scipy's floor 100 × machine epsilon = {SCIPY_MIN_RTOL:.3g} "
                "(scipy would use the floor instead, with only a warning)"
            )

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        model = problem.model
        options = {"jac": model.jacobian} if self.uses_jacobian else {}
        monitor_steps = StepMonitor(self.max_steps or step_budget(problem.params, problem.t_end_s))
        result = solve_ivp(
            model.numba_rhs,
            (0.0, problem.t_end_s),
            problem.initial_state,
            method=guarded_solver(self.solver_class),  # type: ignore[arg-type]  # type[OdeSolver] is hashable
            t_eval=problem.t_out,
            events=radial_event if monitor else None,
            args=(problem.parameter_vector,),
            rtol=tol,
            atol=absolute_tolerance(problem.params, cast(float, tol)),
            step_monitor=monitor_steps,
            **options,
        )
        y = np.full((problem.t_out.size, 4), np.nan)
        y[: result.t.size] = result.y.T
        solution = Solution(t=problem.t_out, y=y, nfev=int(result.nfev), njev=int(result.njev),
                            steps=monitor_steps.accepted)
        if result.status < 0 or result.t.size < problem.t_out.size:
            solution.status = STATUS_FAILED
            reached = float(result.t[-1]) if result.t.size else 0.0
            solution.message = f"solve_ivp status {result.status} after t = {reached:.6g} s: {result.message}"
        if monitor:
            events = np.asarray(result.y_events[0]).reshape(-1, 4)
            solution.streamed = StreamedMetrics(
                turning_points=turning_points(problem, result.t_events[0], events[:, 0], events[:, 1])
            )
        return solution


@register
class ScipyDop853(ScipyIvpIntegrator):
    """Dormand-Prince 8(5,3): explicit Runge-Kutta of order 8 with 12 stages per step (plus 3 for the dense
    output of a step holding output times), error estimated with embedded 5th- and 3rd-order formulas.
    Explicit: bounded stability region; at the tolerances used here the steps are accuracy-limited."""

    name: ClassVar[str] = "scipy_dop853"
    family: ClassVar[str] = "runge-kutta"
    order: ClassVar[int | None] = 8
    solver_class: ClassVar[type[OdeSolver]] = DOP853
    reference: ClassVar[str] = "Hairer, Nørsett & Wanner, Solving ODEs I, §II.10 (DOP853); SciPy solve_ivp"


@register
class ScipyRk45(ScipyIvpIntegrator):
    """Dormand-Prince 5(4): explicit Runge-Kutta of order 5 with an embedded 4th-order error estimate, 6 new
    right-hand-side calls per step attempt (first-same-as-last), quartic dense output. Explicit: bounded
    stability region, steps accuracy-limited here."""

    name: ClassVar[str] = "scipy_rk45"
    family: ClassVar[str] = "runge-kutta"
    order: ClassVar[int | None] = 5
    solver_class: ClassVar[type[OdeSolver]] = RK45
    reference: ClassVar[str] = "Dormand & Prince, J. Comput. Appl. Math. 6, 19 (1980); SciPy solve_ivp"


@register
class ScipyLsoda(ScipyIvpIntegrator):
    """LSODA (ODEPACK): variable-order Adams (orders 1-12) that switches automatically to BDF (orders 1-5)
    when it detects stiffness; the pendulum is not stiff, so it normally stays with Adams (functional
    iteration, no Jacobian). Stability: the Adams formulas have bounded stability regions; LSODA switches to
    BDF when it estimates that stability rather than accuracy limits the step (Petzold 1983), which an undamped
    oscillator at these tolerances does not cause. Gets the analytic Jacobian for the Newton iteration of its
    BDF mode."""

    name: ClassVar[str] = "scipy_lsoda"
    family: ClassVar[str] = "multistep"
    order: ClassVar[int | None] = None
    solver_class: ClassVar[type[OdeSolver]] = LSODA
    uses_jacobian: ClassVar[bool] = True
    reference: ClassVar[str] = "Petzold, SIAM J. Sci. Stat. Comput. 4, 136 (1983); Hindmarsh, ODEPACK (1983)"
