"""heyoka's compiled integrator is reused per thread (integrators.methods.heyoka_taylor.working_integrator): a reused
integrator gives bitwise the results of a fresh copy, whatever ran on it before, with and without the event,
and threads never share one."""

from __future__ import annotations

import copy
import threading

import numpy as np
import pytest

from foucault_bench.integrators import Problem, get_integrator
from foucault_bench.integrators.adaptive import heyoka_tolerance
from foucault_bench.integrators.methods.heyoka_taylor import _compiled_template, working_integrator
from foucault_bench.models import MODELS, PendulumParameters

T_OUT = np.linspace(0.0, 60.0, 61)
PANTHEON = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
OTHER = PendulumParameters(length_m=67.0, latitude_deg=-20.0, amplitude_m=3.0)  # same ε, other parameters
TOL = 1e-10


def _fresh_copy_run(problem: Problem, monitor: bool) -> tuple[np.ndarray, int, np.ndarray | None]:
    """What the adapter computed before it reused integrators: a fresh copy of the template for the run."""
    integrator = copy.copy(_compiled_template(problem.model, "double", heyoka_tolerance(problem.params, TOL),
                                              monitor))
    integrator.state[:] = problem.initial_state
    integrator.pars[:] = problem.model.heyoka_parameters(problem.parameter_vector)
    *_, steps, _, states = integrator.propagate_grid(problem.t_out)
    rows = np.array(integrator.nt_events[0].callback.rows).reshape(-1, 3) if monitor else None
    return np.asarray(states), steps, rows


@pytest.mark.parametrize("monitor", [False, True])
@pytest.mark.parametrize("model_name", ["linear", "spherical"])
def test_reused_integrator_is_bitwise_a_fresh_one(model_name: str, monitor: bool) -> None:
    heyoka = get_integrator("heyoka_taylor")
    problem = Problem(MODELS[model_name], PANTHEON, T_OUT)
    other = Problem(MODELS[model_name], OTHER, T_OUT)
    assert heyoka_tolerance(PANTHEON, TOL) == heyoka_tolerance(OTHER, TOL)  # both runs use one working copy
    states, steps, rows = _fresh_copy_run(problem, monitor)
    first = heyoka.solve(problem, tol=TOL, monitor=monitor)
    heyoka.solve(other, tol=TOL, monitor=monitor)  # other state, parameters and events on the same copy
    again = heyoka.solve(problem, tol=TOL, monitor=monitor)
    for solution in (first, again):
        assert solution.status == "ok", solution.message
        assert solution.y.tobytes() == states.tobytes() and solution.steps == steps
        if monitor:  # the same turning points, none left over from the runs before
            assert solution.streamed.turning_points.shape[0] == rows.shape[0] - 1  # the release is dropped
            assert solution.streamed.turning_points.tobytes() == rows[1:].tobytes()
    assert working_integrator(problem.model, "double", heyoka_tolerance(PANTHEON, TOL), monitor) is \
        working_integrator(other.model, "double", heyoka_tolerance(OTHER, TOL), monitor)


def test_threads_get_their_own_integrator_and_the_same_results() -> None:
    heyoka = get_integrator("heyoka_taylor")
    problems = [Problem(MODELS["spherical"], params, T_OUT) for params in (PANTHEON, OTHER)]
    expected = [heyoka.solve(problem, tol=TOL, monitor=False).y.tobytes() for problem in problems]
    key = (problems[0].model, "double", heyoka_tolerance(PANTHEON, TOL), False)
    found: dict[int, list] = {}

    def work(index: int) -> None:
        results = [heyoka.solve(problems[(index + n) % 2], tol=TOL, monitor=False).y.tobytes() for n in range(6)]
        found[index] = [results, working_integrator(*key)]  # kept alive: ids stay distinct

    threads = [threading.Thread(target=work, args=(index,)) for index in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for index, (results, _) in found.items():
        assert results == [expected[(index + n) % 2] for n in range(6)]
    assert len({id(integrator) for _, integrator in found.values()} | {id(working_integrator(*key))}) == 3
