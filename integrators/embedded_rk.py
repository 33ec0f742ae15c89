"""The compiled embedded Runge-Kutta integrators: ``EmbeddedRungeKutta``, the base of every pair given as a
``ButcherTableau`` (a subclass declares ``tableau`` and its facts and registers), the driver cache, the check that a
pair declared to take the steps of a scipy solver has that solver's tableau (``scipy_twin_problems``,
``scipy_twins``).

The driver, its step-size control and its floating-point order are ``integrators.embedded_driver``.
"""

from __future__ import annotations

import functools
from typing import Any, Callable, ClassVar, cast

import numpy as np
from scipy.integrate import OdeSolver

from foucault_bench.integrators.adaptive import AdaptiveIntegrator, absolute_tolerance, step_budget, turning_points
from foucault_bench.integrators.base import STATUS_FAILED, Integrator, Problem, Solution, StreamedMetrics
from foucault_bench.integrators.embedded_driver import CODE_OK, MESSAGES, STATE_SIZE, build_driver
from foucault_bench.integrators.explicit_rk import ExplicitRungeKutta
from foucault_bench.integrators.tableau import ButcherTableau
from foucault_bench.models import Model


@functools.lru_cache(maxsize=None)
def compiled_driver(model: Model, tableau: ButcherTableau) -> Callable:
    """The driver for ``model`` and ``tableau`` (compiled on first use, cached on disk by numba)."""
    low = tableau.secondary_error_weights
    hairer = tableau.dense_hairer is not None
    dense = np.asarray(tableau.dense_hairer, dtype=np.float64) if hairer else tableau.dense_matrix()
    return build_driver(model.numba_acceleration, np.ascontiguousarray(tableau.extended_a()),
                        np.asarray(tableau.b, dtype=np.float64), np.asarray(tableau.error_weights, dtype=np.float64),
                        np.asarray(low if low is not None else tableau.error_weights, dtype=np.float64),
                        low is not None, np.ascontiguousarray(dense), hairer, tableau.stages,
                        tableau.extra_stages, -1.0 / (tableau.error_estimator_order + 1),
                        tableau.error_estimator_order)


def scipy_twin_problems(tableau: ButcherTableau, solver: Any) -> list[str]:
    """How ``tableau`` differs from scipy's ``solver`` (none when it is scipy's pair): stage count, orders, and
    the nodes, coefficients and weights c, A, b to within a few units of round-off."""
    problems = [f"{what} {mine} against scipy's {theirs}" for what, mine, theirs in (
        ("stages", tableau.stages, solver.n_stages), ("order", tableau.order, solver.order),
        ("error estimator order", tableau.error_estimator_order, solver.error_estimator_order)) if mine != theirs]
    if problems:
        return problems
    a = np.asarray(tableau.a, dtype=np.float64).reshape(tableau.stages, tableau.stages)[:, : solver.A.shape[1]]
    for what, mine, theirs in (("c", np.asarray(tableau.c), solver.C), ("A", a, solver.A),
                               ("b", np.asarray(tableau.b), solver.B)):
        if not np.allclose(mine, theirs, rtol=0.0, atol=4 * np.finfo(np.float64).eps):
            problems.append(f"{what} differs from scipy's")
    return problems


class EmbeddedRungeKutta(AdaptiveIntegrator):
    """Base of the compiled embedded Runge-Kutta integrators: a subclass declares ``tableau`` (its ``order``
    follows from it) and the usual facts.

    Options: ``max_steps`` caps the accepted steps of one run (default ``integrators.adaptive.step_budget``);
    reaching it gives a ``failed`` solution, as for scipy's integrators.
    """

    tableau: ClassVar[ButcherTableau]
    family: ClassVar[str] = "runge-kutta"
    cost_basis: ClassVar[str] = "compiled"
    steps_of: ClassVar[type[OdeSolver] | None] = None
    """scipy's ``RungeKutta`` solver whose steps this integrator takes (same tableau, error norm, controller and
    initial step: the tests compare them step for step with the registered integrator of that solver), or
    None. Checked when the class is made (``scipy_twin_problems``)."""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "tableau" in cls.__dict__:
            if not (cls.tableau.is_embedded and cls.tableau.has_dense_output):
                raise TypeError(f"{cls.__name__}: the adaptive driver needs a tableau with error weights and a "
                                f"dense output ({cls.tableau.name!r} has {'no error weights' if not cls.tableau.is_embedded else 'no dense output'}; "
                                "a plain tableau is stepped by integrators.explicit_rk.ExplicitRungeKutta)")
            cls.order = cls.tableau.order
        twin = cls.__dict__.get("steps_of")
        if twin is not None:
            problems = scipy_twin_problems(cls.tableau, twin)
            if problems:
                raise TypeError(f"{cls.__name__}.steps_of = {twin.__name__}: " + "; ".join(problems))

    main_method_unmeasurable: ClassVar[str] = ""
    """Why the order of the main method cannot be observed by the order sweep of ``foucault-bench selftest``
    (``bench.gate.conformance``), when it cannot in double precision and its coefficients are not known to more
    digits (``ButcherTableau.exact``, stepped in 34 digits instead): then ``fixed_step_method`` is None."""

    def fixed_step_method(self) -> Integrator | None:
        """The pair's main method (c, A, b, order of ``tableau``, without error weights or dense output) stepped
        at fixed steps by ``integrators.explicit_rk``: the formula whose order the pair declares (None when
        ``main_method_unmeasurable`` says why its order cannot be observed)."""
        if self.main_method_unmeasurable:
            return None
        pair = self.tableau
        main = ButcherTableau(name=pair.name, c=pair.c, a=pair.a, b=pair.b, order=pair.order, reference=pair.reference)
        attributes = {"name": f"{self.name}_main_method", "tableau": main, "reference": pair.reference}
        return type(f"{type(self).__name__}MainMethod", (ExplicitRungeKutta,), attributes)()

    def __init__(self, max_steps: int | None = None) -> None:
        if max_steps is not None and max_steps < 1:
            raise ValueError(f"max_steps must be a positive number of steps, got {max_steps!r}")
        self.max_steps = max_steps

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        limit = self.step_limit(problem)
        out = np.full((problem.t_out.size, STATE_SIZE), np.nan)
        events = np.empty((self.event_capacity(problem) if monitor else 0, 3))
        code, t_reached, nfev, steps, rejected, n_events = compiled_driver(problem.model, self.tableau)(
            problem.initial_state, problem.parameter_vector, problem.t_out, float(cast(float, tol)),
            absolute_tolerance(problem.params, cast(float, tol)), limit, monitor, out, events, self.stage_buffer(),
        )
        return self.driver_solution(problem, out, limit, int(code), float(t_reached), int(nfev), int(steps),
                                    int(rejected), events[:n_events] if monitor else None)

    def step_limit(self, problem: Problem) -> int:
        """Most accepted steps of a run: ``max_steps`` or ``integrators.adaptive.step_budget``."""
        return self.max_steps or step_budget(problem.params, problem.t_end_s)

    @staticmethod
    def event_capacity(problem: Problem) -> int:
        """Rows of the turning-point buffer: 2.2 per small-swing period (a swing has 2) and 16 more."""
        return int(2.2 * problem.t_end_s / problem.params.small_swing_period_s) + 16

    def stage_buffer(self) -> np.ndarray:
        """The driver's stage array (the stages, the first-same-as-last one and the dense output's extras)."""
        return np.empty((self.tableau.stages + 1 + self.tableau.extra_stages, STATE_SIZE))

    @staticmethod
    def driver_solution(problem: Problem, out: np.ndarray, limit: int, code: int, t_reached: float, nfev: int,
                        steps: int, rejected: int, events: np.ndarray | None) -> Solution:
        """The ``Solution`` of one driver run from what it wrote and returned (``events``: the turning points
        found, ``None`` without ``monitor``)."""
        solution = Solution(t=problem.t_out, y=out, nfev=nfev, njev=0, steps=steps, rejected_steps=rejected)
        if code != CODE_OK:
            solution.status = STATUS_FAILED
            solution.message = MESSAGES[code].format(limit=limit, t=t_reached)
        if events is not None:
            solution.streamed = StreamedMetrics(turning_points=turning_points(
                problem, events[:, 0], events[:, 1], events[:, 2]))
        return solution


def scipy_twins() -> dict[str, str]:
    """Registered compiled pair → the registered scipy integrator whose solver it takes the steps of
    (``EmbeddedRungeKutta.steps_of`` against ``ScipyIvpIntegrator.solver_class``), in name order; a pair whose
    solver no registered integrator drives is left out."""
    from foucault_bench.integrators.registry import REGISTRY

    by_solver = {solver: name for name, integrator in REGISTRY.items()
                 if (solver := getattr(integrator, "solver_class", None)) is not None}
    return {name: by_solver[integrator.steps_of] for name, integrator in sorted(REGISTRY.items())
            if isinstance(integrator, EmbeddedRungeKutta) and integrator.steps_of in by_solver}
