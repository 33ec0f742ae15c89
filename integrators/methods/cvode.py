"""SUNDIALS CVODE with compiled callbacks: variable-order, variable-step linear multistep methods in Nordsieck
form (``cvode_adams``, ``cvode_bdf``), and what both CVODE paths of the suite share.

CVODE (Hindmarsh et al., ACM TOMS 31, 363 (2005); SUNDIALS CVODE user guide) solves the implicit corrector of
each step by Newton iteration with a dense direct linear solver, for Adams as for BDF (the configuration
scikit-sundae uses, so that ``cvode_*`` and ``cvode_*_py`` run the same algorithm). Configuration
(``CvodeIntegrator.settings``, the same values for both paths):

* **Tolerances.** ``rtol = tol`` and ``atol = tol × (R, R, kR, kR)`` (``integrators.adaptive``: R the release
  amplitude, k = √(g/L)), so the error per step is about tol × the scale of the swing in every component.
* **Method.** ``CV_ADAMS`` with maximum order 12 or ``CV_BDF`` with maximum order 5 (CVODE's and
  scikit-sundae's defaults); Newton iteration (at most 3 iterations, 10 convergence failures per step);
  initial step, minimum and maximum step left to CVODE (0); stop time at the last output time.
* **Right-hand side and Jacobian.** Compiled from the model's one force source: ``Model.numba_rhs_into`` and
  ``Model.numba_jacobian_into`` (heyoka's symbolic derivative of the model's expressions, compiled by numba),
  called by CVODE as numba ``cfunc`` callbacks (``integrators.cvode_library``); ``analytic_jacobian=False``
  uses CVODE's internal dense difference-quotient Jacobian instead, whose 4 right-hand-side calls per Jacobian
  (``CVodeGetNumLinRhsEvals``) are added to ``nfev``.
* **Step limit.** ``max_num_steps`` is CVODE's limit per output interval (default
  ``integrators.adaptive.step_budget`` of the longest interval); reaching it gives a ``failed`` solution with
  CVODE's flag and the words "max_num_steps", as does any negative CVODE flag.
* **Output.** Values at the output times come from CVODE's interpolating polynomial (``CV_NORMAL`` mode),
  which does not change the steps taken after the first (the first output time enters CVODE's initial step
  estimate: ``output_span``); the timed call integrates to the output grid and nothing else (no
  root finding): turning points are located on the grid by ``bench.problems.turning_points``, the same
  procedure for every integrator.
* **Counters.** ``nfev`` (CVodeGetNumRhsEvals, plus CVodeGetNumLinRhsEvals), ``njev`` (CVodeGetNumJacEvals),
  ``steps`` (CVodeGetNumSteps) and ``rejected_steps`` (CVodeGetNumErrTestFails: steps rejected by the local
  error test; steps retried after a corrector convergence failure are in ``extra``).
* **Cost basis.** ``cost_basis = "compiled"``: no Python runs during a solve (the output loop is numba code,
  the callbacks are C functions), so the time is CVODE's own. ``cvode_adams_py`` / ``cvode_bdf_py``
  (``integrators.methods.cvode_py``) are the same solves driven by scikit-sundae with Python callbacks.

SUNDIALS prints warnings and errors on stderr; ``Integrator.solve`` silences the process's descriptors while
it runs. If the SUNDIALS libraries cannot be loaded the run is a ``failed`` row whose message names what is
missing (``integrators.cvode_library.SundialsUnavailable``).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from foucault_bench.integrators.adaptive import AdaptiveIntegrator, absolute_tolerance, step_budget
from foucault_bench.integrators.base import STATUS_FAILED, Problem, Solution
from foucault_bench.integrators.cvode_library import CVODE_FLAGS, CvodeSettings, load_sundials, run_cvode
from foucault_bench.integrators.registry import register

MAX_ORDER = {"Adams": 12, "BDF": 5}
"""CVODE's largest order per method (its defaults; scikit-sundae sets the same)."""


def output_span(t_out: np.ndarray) -> np.ndarray:
    """The times CVODE is asked for: the release t = 0 followed by the output grid, with a midpoint added to a
    two-point span (given a two-point span, scikit-sundae returns every internal step instead). Both CVODE
    paths use this span: CVODE's initial step estimate depends on the first output time (CVODE user guide,
    "Initial step size"), so the same span is part of "the same settings"."""
    t_span = np.union1d([0.0], t_out)
    if t_span.size == 2:
        t_span = np.array([t_span[0], 0.5 * (t_span[0] + t_span[1]), t_span[1]])
    return t_span


class CvodeIntegrator(AdaptiveIntegrator):
    """What the CVODE integrators share: options, settings and the failure message; subclasses name the
    linear multistep family and how CVODE is driven.

    Options (constructor): ``max_num_steps`` (CVODE's step limit per output interval, default from
    ``integrators.adaptive.step_budget``) and ``analytic_jacobian`` (default ``True``).
    """

    family: ClassVar[str] = "multistep"
    order: ClassVar[int | None] = None
    method: ClassVar[str]
    reference: ClassVar[str]
    cost_basis: ClassVar[str]
    """``"compiled"`` (no Python during a solve) or ``"python-driven"`` (Python callbacks per evaluation)."""

    def __init__(self, max_num_steps: int | None = None, analytic_jacobian: bool = True) -> None:
        if max_num_steps is not None and max_num_steps < 1:
            raise ValueError(f"max_num_steps must be a positive number of steps, got {max_num_steps!r}")
        self.max_num_steps = max_num_steps
        self.analytic_jacobian = analytic_jacobian

    def settings(self, problem: Problem, tol: float) -> CvodeSettings:
        """The CVODE configuration of a solve (module docstring)."""
        t_span = output_span(problem.t_out)
        return CvodeSettings(
            method=self.method,
            max_order=MAX_ORDER[self.method],
            rtol=tol,
            atol=absolute_tolerance(problem.params, tol),
            max_num_steps=self.max_num_steps or step_budget(problem.params, float(np.max(np.diff(t_span)))),
            t_span=t_span,
            initial_state=problem.initial_state,
            analytic_jacobian=self.analytic_jacobian,
        )


class CvodeCompiled(CvodeIntegrator):
    """CVODE driven from compiled code (``integrators.cvode_library``).

    Extra option: ``library_dir``, a directory holding the SUNDIALS shared libraries (default: the ones in
    scikit-sundae's wheel).
    """

    cost_basis: ClassVar[str] = "compiled"

    def __init__(self, max_num_steps: int | None = None, analytic_jacobian: bool = True,
                 library_dir: str | None = None) -> None:
        super().__init__(max_num_steps=max_num_steps, analytic_jacobian=analytic_jacobian)
        self.library_dir = library_dir

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        assert tol is not None  # an adaptive integrator's setting (validate_setting)
        library = load_sundials(self.library_dir)
        settings = self.settings(problem, tol)
        run = run_cvode(library, problem.model, settings, problem.parameter_vector)
        counters = run.counters
        solution = Solution(
            t=problem.t_out,
            y=run.y[np.searchsorted(settings.t_span, problem.t_out)],
            nfev=counters["CVodeGetNumRhsEvals"] + counters["CVodeGetNumLinRhsEvals"],
            njev=counters["CVodeGetNumJacEvals"],
            steps=counters["CVodeGetNumSteps"],
            rejected_steps=counters["CVodeGetNumErrTestFails"],
            extra={"cvode_flag": run.flag,
                   "nonlinear_convergence_failures": counters["CVodeGetNumNonlinSolvConvFails"]},
        )
        if run.flag < 0:
            solution.status = STATUS_FAILED
            name, description = CVODE_FLAGS.get(run.flag, ("?", "see the CVODE user guide"))
            if run.flag == -1:
                description += f" (max_num_steps = {settings.max_num_steps})"
            solution.message = f"CVODE flag {run.flag} ({name}) at t = {run.t_reached:.6g} s: {description}"
        return solution


@register
class CvodeAdams(CvodeCompiled):
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
class CvodeBdf(CvodeCompiled):
    """CVODE backward differentiation formulas, variable order 1-5 and variable step (Nordsieck form).

    Order: chosen by CVODE between 1 and 5 (``order`` = None). BDF1-2 are A-stable, BDF3-5 only A(α)-stable
    (α = 86.03°, 73.35°, 51.84°), and the formulas damp oscillations: built for stiff problems, here a
    baseline that needs more steps than Adams for the same tolerance on an undamped oscillator. CVODE's BDF
    stability-limit detection is off (its default, as in scikit-sundae).
    """

    name: ClassVar[str] = "cvode_bdf"
    method: ClassVar[str] = "BDF"
    reference: ClassVar[str] = (
        "Hindmarsh et al., ACM TOMS 31, 363 (2005); Hairer & Wanner, Solving ODEs II, §V.2 (BDF stability)"
    )
