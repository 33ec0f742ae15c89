"""SUNDIALS CVODE through scikit-sundae's Python interface (``cvode_adams_py``, ``cvode_bdf_py``): what a
Python user of scikit-sundae gets.

The same solves as ``cvode_adams`` / ``cvode_bdf`` (``integrators.methods.cvode``: same SUNDIALS build, same
``CvodeIntegrator.settings``: method, maximum order, tolerances, step limit, Newton iteration with the dense
linear solver, stop time), driven by ``sksundae.cvode.CVODE``: CVODE calls back into Python for every
right-hand-side evaluation (a closure around ``Model.numba_rhs_into``, since scikit-sundae 1.2 cannot take an
array as ``userdata``: its option check evaluates the array's truth value) and every Jacobian
(``Model.numba_jacobian_into``, the compiled path's Jacobian), and loops over the output times in its own
code. Both paths take the same steps and return bitwise-equal states (tests/test_cvode.py); the cost
differs by the binding's work per callback, so ``cost_basis = "python-driven"``. Tolerance mapping, order
and stability: as ``integrators.methods.cvode``.

Counters: ``nfev`` and ``njev`` from scikit-sundae's result (with ``analytic_jacobian=False``, ``nfev`` adds
the 4 right-hand-side calls of each difference-quotient Jacobian, as the compiled path does). ``steps`` and
``rejected_steps`` are ``None``: scikit-sundae 1.2 exposes only CVodeGetNumRhsEvals and CVodeGetNumJacEvals,
and counting steps through its one-step mode would add Python work to every step.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from foucault_bench.integrators.base import STATUS_FAILED, Problem, Solution
from foucault_bench.integrators.methods.cvode import CvodeAdams, CvodeBdf, CvodeIntegrator
from foucault_bench.integrators.registry import register

STATE_SIZE = 4


class CvodePython(CvodeIntegrator):
    """CVODE through ``sksundae.cvode.CVODE`` with Python callbacks; subclasses name the method."""

    cost_basis: ClassVar[str] = "python-driven"

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        from sksundae.cvode import CVODE

        assert tol is not None  # an adaptive integrator's setting (validate_setting)
        settings = self.settings(problem, tol)
        p = problem.parameter_vector
        rhs_into = problem.model.numba_rhs_into

        def rhs(t, y, yp):
            rhs_into(t, y, yp, p)

        tspan = settings.t_span  # never two points (``cvode.output_span``): that is scikit-sundae's one-step mode
        options = {
            "method": settings.method,
            "max_order": settings.max_order,
            "rtol": settings.rtol,
            "atol": settings.atol,
            "max_num_steps": settings.max_num_steps,
            "max_nonlin_iters": settings.max_nonlin_iters,
            "max_conv_fails": settings.max_conv_fails,
            "first_step": settings.first_step,
            "min_step": settings.min_step,
            "max_step": settings.max_step,
            "linsolver": "dense",
        }
        if settings.analytic_jacobian:
            jacobian_into = problem.model.numba_jacobian_into

            def jacobian(t, y, yp, jj):
                jacobian_into(t, y, jj, p)

            options["jacfn"] = jacobian

        result = CVODE(rhs, **options).solve(tspan, settings.initial_state)

        # Rows at the requested times; a failed run ends with a row at the time it stopped, which is dropped.
        n_rows = len(result.t)
        on_grid = np.asarray(result.t) == tspan[:n_rows]
        y_span = np.full((tspan.size, STATE_SIZE), np.nan)
        y_span[:n_rows][on_grid] = np.asarray(result.y)[on_grid]
        y = y_span[np.searchsorted(tspan, problem.t_out)]

        nfev = int(result.nfev) + (0 if settings.analytic_jacobian else STATE_SIZE * int(result.njev))
        solution = Solution(t=problem.t_out, y=y, nfev=nfev, njev=int(result.njev),
                            extra={"cvode_flag": int(result.status)})
        if result.status < 0 or not np.all(on_grid) or n_rows < tspan.size:
            solution.status = STATUS_FAILED
            solution.message = f"CVODE flag {result.status} at t = {float(result.t[-1]):.6g} s: {result.message}"
        return solution


PYTHON_DRIVEN = "\n\n    Driven by scikit-sundae with Python callbacks (what a Python user of scikit-sundae gets).\n"


@register
class CvodeAdamsPy(CvodePython):
    __doc__ = (CvodeAdams.__doc__ or "").rstrip() + PYTHON_DRIVEN
    name: ClassVar[str] = "cvode_adams_py"
    method: ClassVar[str] = CvodeAdams.method
    reference: ClassVar[str] = f"{CvodeAdams.reference}; scikit-sundae"


@register
class CvodeBdfPy(CvodePython):
    __doc__ = (CvodeBdf.__doc__ or "").rstrip() + PYTHON_DRIVEN
    name: ClassVar[str] = "cvode_bdf_py"
    method: ClassVar[str] = CvodeBdf.method
    reference: ClassVar[str] = f"{CvodeBdf.reference}; scikit-sundae"
