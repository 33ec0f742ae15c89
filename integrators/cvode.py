"""SUNDIALS CVODE through scikit-sundae: variable-order, variable-step linear multistep methods in Nordsieck
form (``cvode_adams``, ``cvode_bdf``).

CVODE (Hindmarsh et al., ACM TOMS 31, 363 (2005); SUNDIALS CVODE user guide) solves the implicit corrector of
each step by Newton iteration; scikit-sundae always attaches a dense direct linear solver, so both methods use
the Jacobian. Configuration used here:

* **Tolerances.** ``rtol = tol`` and ``atol = tol × (R, R, kR, kR)`` (``integrators.adaptive``: R the release
  amplitude, k = √(g/L)), so the error per step is about tol × the scale of the swing in every component.
* **Right-hand side.** ``Model.numba_rhs_into`` (t, y, out, p), called from a closure that binds p
  (scikit-sundae 1.2 cannot take an array as ``userdata``: its option check evaluates the array's truth value).
* **Jacobian.** ``Model.jacobian_into``: heyoka's symbolic derivative of the model's own expressions, compiled
  (``analytic_jacobian=True``, the default). With ``analytic_jacobian=False`` CVODE's internal dense
  difference-quotient Jacobian is used, which costs one extra right-hand-side call per state component and
  Jacobian; ``nfev`` then adds those 4 × ``njev`` calls, which CVODE counts separately from ``nfev``
  (CVodeGetNumRhsEvals excludes the linear solver's calls).
* **Step limit.** ``max_num_steps`` is CVODE's limit per output interval (default
  ``integrators.adaptive.step_budget`` of the longest interval); reaching it gives a ``failed`` solution with
  CVODE's message ("Could not reach endpoint after 'max_num_steps'"), as does any negative CVODE flag.
* **Turning points.** CVODE's root finding on r·ṙ = xẋ + yẏ, non-terminal, direction −1 (radius maxima).
  CVODE does not report the release point t = 0 as a root.
* **Counters.** ``nfev`` and ``njev`` come from CVODE's statistics. ``steps`` and ``rejected_steps`` are
  ``None``: scikit-sundae 1.2.0 (the latest release) exposes only CVodeGetNumRhsEvals and
  CVodeGetNumJacEvals, not CVodeGetNumSteps or CVodeGetNumErrTestFails, and counting steps through its
  one-step mode would add Python work to every step (and, with events, work growing with the event count).
* **Output.** Values at the output times come from CVODE's interpolating polynomial (CV_NORMAL mode), which
  does not change the steps taken. SUNDIALS prints warnings and errors on stderr; ``Integrator.solve`` silences
  the process's descriptors while it runs.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from foucault_bench.integrators.adaptive import AdaptiveIntegrator, absolute_tolerance, step_budget, turning_points
from foucault_bench.integrators.base import STATUS_FAILED, Problem, Solution, StreamedMetrics
from foucault_bench.integrators.registry import register

STATE_SIZE = 4


class CvodeIntegrator(AdaptiveIntegrator):
    """Common driver of the CVODE methods; subclasses name the linear multistep family.

    Options (constructor): ``max_num_steps`` (CVODE's step limit per output interval, default from
    ``integrators.adaptive.step_budget``) and ``analytic_jacobian`` (default ``True``).
    """

    family: ClassVar[str] = "multistep"
    order: ClassVar[int | None] = None
    method: ClassVar[str]
    reference: ClassVar[str]

    def __init__(self, max_num_steps: int | None = None, analytic_jacobian: bool = True) -> None:
        if max_num_steps is not None and max_num_steps < 1:
            raise ValueError(f"max_num_steps must be a positive number of steps, got {max_num_steps!r}")
        self.max_num_steps = max_num_steps
        self.analytic_jacobian = analytic_jacobian

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        from sksundae.cvode import CVODE

        p = problem.parameter_vector
        rhs_into = problem.model.numba_rhs_into

        def rhs(t, y, yp):
            rhs_into(t, y, yp, p)

        # CVODE integrates from tspan[0] = 0 (the release); a two-point tspan would switch scikit-sundae to
        # returning every internal step, so such a grid gets a midpoint, dropped again below.
        tspan = np.union1d([0.0], problem.t_out)
        if tspan.size == 2:
            tspan = np.array([tspan[0], 0.5 * (tspan[0] + tspan[1]), tspan[1]])
        options = {
            "method": self.method,
            "rtol": tol,
            "atol": absolute_tolerance(problem.params, tol),
            "max_num_steps": self.max_num_steps or step_budget(problem.params, float(np.max(np.diff(tspan)))),
        }
        if self.analytic_jacobian:
            jacobian_into = problem.model.jacobian_into

            def jacobian(t, y, yp, jj):
                jacobian_into(t, y, jj, p)

            options["jacfn"] = jacobian
        if monitor:

            def radial(t, y, g):
                g[0] = y[0] * y[2] + y[1] * y[3]

            radial.terminal = [False]
            radial.direction = [-1]
            options.update(eventsfn=radial, num_events=1)

        result = CVODE(rhs, **options).solve(tspan, problem.initial_state)

        # Rows at the requested times; a failed run ends with a row at the time it stopped, which is dropped.
        n_rows = len(result.t)
        on_grid = np.asarray(result.t) == tspan[:n_rows]
        y_span = np.full((tspan.size, STATE_SIZE), np.nan)
        y_span[:n_rows][on_grid] = np.asarray(result.y)[on_grid]
        y = y_span[np.searchsorted(tspan, problem.t_out)]

        nfev = int(result.nfev) + (0 if self.analytic_jacobian else STATE_SIZE * int(result.njev))
        solution = Solution(t=problem.t_out, y=y, nfev=nfev, njev=int(result.njev),
                            extra={"cvode_flag": int(result.status)})
        if result.status < 0 or not np.all(on_grid) or n_rows < tspan.size:
            solution.status = STATUS_FAILED
            solution.message = f"CVODE flag {result.status} at t = {float(result.t[-1]):.6g} s: {result.message}"
        if monitor:
            events_t = np.zeros(0) if result.t_events is None else np.asarray(result.t_events)
            events_y = np.zeros((0, STATE_SIZE)) if result.y_events is None else np.asarray(result.y_events)
            solution.streamed = StreamedMetrics(
                turning_points=turning_points(problem, events_t, events_y[:, 0], events_y[:, 1])
            )
        return solution


@register
class CvodeAdams(CvodeIntegrator):
    """CVODE Adams-Moulton, variable order 1-12 and variable step (Nordsieck form), Newton-solved corrector.

    Order: chosen by CVODE between 1 and 12 (``order`` = None). Orders 1 and 2 (backward Euler, trapezoidal
    rule) are A-stable; the higher Adams-Moulton formulas have bounded stability regions, so on the pendulum
    (eigenvalues ≈ ±ik) the step is accuracy-limited: the method of choice for non-stiff oscillations.
    """

    name: ClassVar[str] = "cvode_adams"
    method: ClassVar[str] = "Adams"
    reference: ClassVar[str] = (
        "Hindmarsh et al., ACM TOMS 31, 363 (2005); Byrne & Hindmarsh, ACM TOMS 1, 71 (1975); "
        "Hairer, Nørsett & Wanner, Solving ODEs I, §III.1"
    )


@register
class CvodeBdf(CvodeIntegrator):
    """CVODE backward differentiation formulas, variable order 1-5 and variable step (Nordsieck form).

    Order: chosen by CVODE between 1 and 5 (``order`` = None). BDF1-2 are A-stable, BDF3-5 only A(α)-stable
    (α = 86.03°, 73.35°, 51.84°), and the formulas damp oscillations: built for stiff problems, here a
    baseline that needs more steps than Adams for the same tolerance on an undamped oscillator. CVODE's BDF
    stability-limit detection is not exposed by scikit-sundae.
    """

    name: ClassVar[str] = "cvode_bdf"
    method: ClassVar[str] = "BDF"
    reference: ClassVar[str] = (
        "Hindmarsh et al., ACM TOMS 31, 363 (2005); Hairer & Wanner, Solving ODEs II, §V.2 (BDF stability)"
    )
