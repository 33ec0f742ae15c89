"""Many members of one configuration in one call: the compiled loops over members, and the dispatch by scheme.

A *batch* is a list of problems of one model on one output grid (an ensemble's members: their own parameters
and release states) run by one integrator at one setting. ``solve_batch`` returns one ``Solution`` per member,
in the layout ``Integrator.solve`` gives it (validated the same way, ``Integrator.finish`` applied):

* **Fixed-step schemes** (``FixedStepIntegrator``: the Runge-Kutta tableaux, Nyström, Verlet and its
  compositions, Boris, the Euler schemes, Gauss collocation): one compiled loop over the members that calls the
  scheme's own compiled loop (``FixedStepIntegrator.kernel``) on each member's rows of preallocated
  (members × grid × 4) arrays. Each member runs the same machine code on the same inputs as alone, so the
  results are bitwise those of one-by-one runs (``tests/test_batch.py``); one Python call replaces one per
  member. The turning-point buffer has the largest member's capacity (equal for members of one length and
  duration; alone, each has 2.2 rows per period, more than a swing fills).
* **Compiled embedded Runge-Kutta pairs** (``EmbeddedRungeKutta``): the same, a compiled loop over the members
  calling the pair's driver (``compiled_driver``). Every member keeps its own step-size control, so its
  accepted and rejected steps are those of its one-by-one run, bitwise.
* **heyoka** (``heyoka_taylor``): heyoka's batch mode, ``integrators.batch_heyoka``. Its step counts per
  member are its own (heyoka sizes each lane's step from that lane's Taylor coefficients), unlike a vectorised
  solver that steps every member together (diffrax under ``jax.vmap``, diffrax issue #692).
* **Everything else** (CVODE, the scipy integrators, the quadruple-precision reference): one member after
  another through ``Integrator.solve``.
"""

from __future__ import annotations

import functools
from typing import Callable, Sequence, cast

import numpy as np

from foucault_bench.integrators.adaptive import absolute_tolerance
from foucault_bench.integrators.base import Integrator, Problem, Solution
from foucault_bench.integrators.embedded_rk import STATE_SIZE, EmbeddedRungeKutta, compiled_driver
from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.models import Model
from foucault_bench.models.jit import jit


def check_batch(problems: Sequence[Problem]) -> None:
    """Raise ``ValueError`` unless the problems share one model and one output grid (at least one member)."""
    if not problems:
        raise ValueError("a batch needs at least one member")
    first = problems[0]
    for index, problem in enumerate(problems):
        if problem.model is not first.model:
            raise ValueError(f"member {index}: model {problem.model.name!r}, not the batch's {first.model.name!r}")
        if not np.array_equal(problem.t_out, first.t_out):
            raise ValueError(f"member {index}: its output grid is not the batch's")


def solve_batch(integrator: Integrator, problems: Sequence[Problem], *, step_s: float | Sequence[float] | None = None,
                tol: float | None = None, monitor: bool = True) -> list[Solution]:
    """Every member's ``Solution``, as ``integrator.solve(problem, step_s=…, tol=…, monitor=…)`` gives it.

    ``step_s`` is one step for every member or one per member (fixed-step schemes; an ensemble at one kh over
    lengths has one step per member). Raises ``ValueError`` for a malformed batch or setting, as ``solve`` does.
    """
    check_batch(problems)
    steps = list(step_s) if isinstance(step_s, Sequence) else [step_s] * len(problems)
    if len(steps) != len(problems):
        raise ValueError(f"{len(steps)} step sizes for {len(problems)} members")
    for problem, step in zip(problems, steps, strict=True):
        integrator.validate_setting(step_s=step, tol=tol)
        integrator.validate_problem(problem, step_s=step)
    run = _batch_runner(integrator, monitor)
    if run is None:
        return [integrator.solve(problem, step_s=step, tol=tol, monitor=monitor)
                for problem, step in zip(problems, steps, strict=True)]
    try:
        solutions = run(integrator, problems, steps, tol, monitor)
    except Exception as exc:  # as Integrator.solve: a library or numerical failure becomes rows, not a crash
        return [Solution.failure(problem.t_out, f"{type(exc).__name__}: {exc}") for problem in problems]
    return [integrator.finish(solution, step_s=step, tol=tol)
            for solution, step in zip(solutions, steps, strict=True)]


def _batch_runner(integrator: Integrator, monitor: bool) -> Callable | None:
    """The batch implementation for the integrator's scheme, ``None`` for member-by-member runs."""
    from foucault_bench.integrators.batch_heyoka import heyoka_batch_runs
    from foucault_bench.integrators.methods.heyoka_taylor import HeyokaTaylor

    if isinstance(integrator, FixedStepIntegrator):
        return _fixed_step_runs
    if isinstance(integrator, EmbeddedRungeKutta):
        return _embedded_runs
    if isinstance(integrator, HeyokaTaylor) and integrator.precision == "double" and not monitor:
        return heyoka_batch_runs
    return None


def stacked(problems: Sequence[Problem]) -> tuple[np.ndarray, np.ndarray]:
    """The members' release states (members × 4) and parameter vectors (members × parameters), C-contiguous."""
    return (np.ascontiguousarray([problem.initial_state for problem in problems]),
            np.ascontiguousarray([problem.parameter_vector for problem in problems]))


@functools.lru_cache(maxsize=None)
def fixed_step_member_loop(kernel: Callable) -> Callable:
    """One compiled loop over members around a fixed-step scheme's compiled loop (``fixed_step.build_kernel``)."""

    @jit
    def member_loop(states0, parameter_vectors, h, n_steps, stride, out, monitor, turning, radius_bound, results):
        for m in range(states0.shape[0]):
            status, steps_done, n_turning, max_rel, slope = kernel(
                states0[m], parameter_vectors[m], h[m], n_steps[m], stride[m], out[m], monitor, turning[m],
                radius_bound[m])
            results[m, 0] = status
            results[m, 1] = steps_done
            results[m, 2] = n_turning
            results[m, 3] = max_rel
            results[m, 4] = slope

    return member_loop


def fixed_step_arrays(integrator: FixedStepIntegrator, problems: Sequence[Problem], steps: Sequence[float],
                      monitor: bool) -> tuple:
    """The member loop's arguments: states, parameters, steps, step counts, strides, output, monitor flag,
    turning-point buffers, divergence radii and the results array (members × 5)."""
    layout = [integrator.steps_for(problem, step) for problem, step in zip(problems, steps, strict=True)]
    states0, parameter_vectors = stacked(problems)
    capacity = max(integrator.turning_capacity(problem) for problem in problems) if monitor else 0
    return (states0, parameter_vectors, np.array([h for _, h, _ in layout]),
            np.array([n for _, _, n in layout], dtype=np.int64), np.array([s for s, _, _ in layout], dtype=np.int64),
            np.full((len(problems), problems[0].t_out.size, 4), np.nan), monitor,
            np.empty((len(problems), capacity, 3)),
            np.array([integrator.radius_bound_m(problem) for problem in problems]), np.zeros((len(problems), 5)))


def _fixed_step_runs(integrator: FixedStepIntegrator, problems: Sequence[Problem], steps: Sequence[float],
                     tol: float | None, monitor: bool) -> list[Solution]:
    arguments = fixed_step_arrays(integrator, problems, steps, monitor)
    fixed_step_member_loop(integrator.kernel(problems[0].model))(*arguments)
    _, _, h, n_steps, _, out, _, turning, _, results = arguments
    return [integrator.kernel_solution(problem, out[m], float(h[m]), int(n_steps[m]), int(results[m, 0]),
                                       int(results[m, 1]), turning[m, : int(results[m, 2])] if monitor else None,
                                       float(results[m, 3]), float(results[m, 4]))
            for m, problem in enumerate(problems)]


@functools.lru_cache(maxsize=None)
def embedded_member_loop(driver: Callable) -> Callable:
    """One compiled loop over members around an embedded pair's compiled driver (``embedded_rk.build_driver``)."""

    @jit
    def member_loop(states0, parameter_vectors, t_out, rtol, atol, max_steps, monitor, out, events, k, results):
        for m in range(states0.shape[0]):
            code, t_reached, nfev, accepted, rejected, n_events = driver(
                states0[m], parameter_vectors[m], t_out, rtol, atol[m], max_steps[m], monitor, out[m], events[m],
                k[m])
            results[m, 0] = code
            results[m, 1] = t_reached
            results[m, 2] = nfev
            results[m, 3] = accepted
            results[m, 4] = rejected
            results[m, 5] = n_events

    return member_loop


def _embedded_runs(integrator: EmbeddedRungeKutta, problems: Sequence[Problem], steps: Sequence[float],
                   tol: float | None, monitor: bool) -> list[Solution]:
    model: Model = problems[0].model
    rtol = float(cast(float, tol))
    states0, parameter_vectors = stacked(problems)
    limits = np.array([integrator.step_limit(problem) for problem in problems], dtype=np.int64)
    capacity = max(integrator.event_capacity(problem) for problem in problems) if monitor else 0
    out = np.full((len(problems), problems[0].t_out.size, STATE_SIZE), np.nan)
    events = np.empty((len(problems), capacity, 3))
    k = np.empty((len(problems), *integrator.stage_buffer().shape))
    atol = np.ascontiguousarray([absolute_tolerance(problem.params, rtol) for problem in problems])
    results = np.zeros((len(problems), 6))
    embedded_member_loop(compiled_driver(model, integrator.tableau))(
        states0, parameter_vectors, problems[0].t_out, rtol, atol, limits, monitor, out, events, k, results)
    return [integrator.driver_solution(problem, out[m], int(limits[m]), int(results[m, 0]), float(results[m, 1]),
                                       int(results[m, 2]), int(results[m, 3]), int(results[m, 4]),
                                       events[m, : int(results[m, 5])] if monitor else None)
            for m, problem in enumerate(problems)]
