"""CVODE's two paths: compiled callbacks (``cvode_adams``, ``cvode_bdf``) against scikit-sundae's Python
interface (``cvode_adams_py``, ``cvode_bdf_py``), the compiled path's counters, and a SUNDIALS library that
cannot be loaded.

The two paths configure the same CVODE (``CvodeIntegrator.settings``) in the same SUNDIALS build and call the
same compiled right-hand side and Jacobian, so every floating-point operation is the same: the tests demand
equal counters and bitwise-equal states, no tolerance. scikit-sundae does not report CVODE's step count; its
one-step mode (``CVODE.step``) advances one internal step per call and, given the same first output time
(which CVODE's initial step estimate uses) and stop time, takes the same steps as the output-grid mode: the
count to compare with CVodeGetNumSteps.
"""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.bench.run.runner import run_matrix
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.integrators import REGISTRY, Problem, get_integrator, unregister
from foucault_bench.integrators.methods.cvode import CvodeAdams, CvodeBdf
from foucault_bench.integrators.cvode_library import SundialsUnavailable, load_sundials
from foucault_bench.models import MODELS, PendulumParameters

LAB = PendulumParameters(length_m=3.0, latitude_deg=45.0, amplitude_m=0.3, release_velocity_m_s=(0.0, 0.05))
CASES = [  # (scene name or parameters, model, duration s, output interval s, tol)
    ("pantheon", "linear", 600.0, 2.0, 1e-8),
    (LAB, "spherical", 60.0, 0.25, 1e-10),
    (LAB, "seed_planar", 60.0, 0.5, 1e-6),
]
METHODS = [("cvode_adams", "cvode_adams_py"), ("cvode_bdf", "cvode_bdf_py")]


def case_problem(scene, model_name: str, duration_s: float, interval_s: float) -> Problem:
    if isinstance(scene, str):
        scene = SCENES[scene].params
    return Problem(MODELS[model_name], scene, np.arange(0.0, duration_s + interval_s / 2, interval_s))


def one_step_count(integrator, problem: Problem, tol: float) -> tuple[int, int]:
    """Steps and right-hand-side evaluations CVODE takes for ``problem``, one step per scikit-sundae call
    (``CVODE.step`` in one-step mode towards the first output time, which CVODE's initial step estimate uses,
    with the stop time at the end, as the output-grid mode has them)."""
    from sksundae.cvode import CVODE

    settings = integrator.settings(problem, tol)
    p, model = problem.parameter_vector, problem.model
    options = {"method": settings.method, "max_order": settings.max_order, "rtol": settings.rtol,
               "atol": settings.atol, "max_num_steps": settings.max_num_steps,
               "jacfn": lambda t, y, yp, jj: model.numba_jacobian_into(t, y, jj, p)}
    solver = CVODE(lambda t, y, yp: model.numba_rhs_into(t, y, yp, p), **options)
    solver.init_step(0.0, settings.initial_state)
    t_end, steps, result = float(settings.t_span[-1]), 0, None
    while result is None or result.t < t_end:
        result = solver.step(float(settings.t_span[1]), "onestep", t_end)
        assert result.status >= 0, result.message
        steps += 1
    return steps, result.nfev


@pytest.mark.parametrize(("compiled", "python"), METHODS)
@pytest.mark.parametrize(("scene", "model_name", "duration_s", "interval_s", "tol"), CASES)
def test_compiled_and_python_paths_take_the_same_steps_to_the_same_bits(compiled, python, scene, model_name,
                                                                         duration_s, interval_s, tol) -> None:
    problem = case_problem(scene, model_name, duration_s, interval_s)
    fast = get_integrator(compiled).solve(problem, tol=tol)
    slow = get_integrator(python).solve(problem, tol=tol)
    assert fast.status == slow.status == "ok", (fast.message, slow.message)
    assert (fast.nfev, fast.njev) == (slow.nfev, slow.njev)
    assert fast.y.tobytes() == slow.y.tobytes()
    assert (fast.steps, fast.nfev) == one_step_count(get_integrator(python), problem, tol)


@pytest.mark.parametrize("cls", [CvodeAdams, CvodeBdf])
def test_paths_agree_with_difference_quotient_jacobians(cls) -> None:
    problem = case_problem(LAB, "spherical", 30.0, 0.25)
    fast = cls(analytic_jacobian=False).solve(problem, tol=1e-9)
    slow = type(get_integrator(f"{cls.name}_py"))(analytic_jacobian=False).solve(problem, tol=1e-9)
    assert fast.status == slow.status == "ok"
    assert (fast.nfev, fast.njev) == (slow.nfev, slow.njev)
    assert fast.y.tobytes() == slow.y.tobytes()


def test_compiled_path_reports_steps_and_rejected_steps() -> None:
    problem = case_problem("pantheon", "linear", 600.0, 2.0)
    solution = get_integrator("cvode_adams").solve(problem, tol=1e-8)
    assert isinstance(solution.steps, int) and isinstance(solution.rejected_steps, int)
    assert 0 < solution.steps < solution.nfev and 0 <= solution.rejected_steps < solution.steps
    # each step evaluates the RHS at least once for its corrector; the first step also evaluates f(t0, y0)
    assert solution.nfev >= solution.steps + solution.rejected_steps


def test_paths_declare_how_their_cost_is_measured() -> None:
    bases = {name: integrator.cost_basis for name, integrator in REGISTRY.items() if name.startswith("cvode")}
    assert bases == {"cvode_adams": "compiled", "cvode_bdf": "compiled",
                     "cvode_adams_py": "python-driven", "cvode_bdf_py": "python-driven"}


def test_loader_names_a_missing_library(tmp_path) -> None:
    with pytest.raises(SundialsUnavailable, match="sundials_core"):
        load_sundials(str(tmp_path / "missing"))
    solution = CvodeAdams(library_dir=str(tmp_path / "missing")).solve(case_problem("pantheon", "linear", 60.0, 2.0),
                                                                       tol=1e-8)
    assert solution.status == "failed"
    assert "SundialsUnavailable" in solution.message and "sundials_core" in solution.message
    assert str(tmp_path / "missing") in solution.message
    assert np.all(np.isnan(solution.y))


def test_loader_checks_the_sundials_configuration(monkeypatch, tmp_path) -> None:
    import foucault_bench.integrators.cvode_library as library

    for key, value, words in [("SUNDIALS_FLOAT_TYPE", "float", "sunrealtype"),
                              ("SUNDIALS_INT_TYPE", "short", "sunindextype"),
                              ("SUNDIALS_VERSION", "6.7.0", "SUNDIALS 6.7.0")]:
        configuration = {**library.sundials_configuration(), key: value}
        monkeypatch.setattr(library, "sundials_configuration", lambda changed=configuration: changed)
        with pytest.raises(SundialsUnavailable, match=words):
            load_sundials(str(tmp_path / key))  # a new directory: load_sundials caches only successes
        monkeypatch.undo()


PLUGIN = '''
"""Test-only: the compiled CVODE pointed at a directory without SUNDIALS (registered when imported)."""
from typing import ClassVar

from foucault_bench.integrators import register
from foucault_bench.integrators.methods.cvode import CvodeAdams


@register
class CvodeWithoutLibraries(CvodeAdams):
    name: ClassVar[str] = "test_cvode_without_libraries"

    def __init__(self):
        super().__init__(library_dir={directory!r})
'''


def test_unloadable_library_is_a_failed_row_and_the_matrix_finishes(tmp_path, monkeypatch) -> None:
    module_name = "cvode_without_libraries_plugin"
    (tmp_path / f"{module_name}.py").write_text(PLUGIN.format(directory=str(tmp_path / "no-sundials")))
    monkeypatch.syspath_prepend(str(tmp_path))
    matrix_path = tmp_path / "matrix.toml"
    matrix_path.write_text(textwrap.dedent(f"""
        plugins = ["{module_name}"]
        integrators = ["test_cvode_without_libraries", "cvode_adams"]
        tol = [1e-6]
        [scene.pantheon_10min]
        base = "pantheon"
        duration_s = 600.0
        [timing]
        min_repeats = 1
        min_total_s = 0.0
        """))
    try:
        with ResultsStore(tmp_path / "results.sqlite") as store:
            run_matrix(load_matrix(matrix_path), store, jobs=1, progress=False)
            rows = store.frame().set_index("integrator")
    finally:
        unregister("test_cvode_without_libraries")
    failed = rows.loc["test_cvode_without_libraries"]
    assert failed["status"] == "failed"
    assert "sundials_core" in failed["message"] and "not found" in failed["message"]
    assert rows.loc["cvode_adams", "status"] == "ok"
    assert rows.loc["cvode_adams", "steps"] > 0 and rows.loc["cvode_adams", "rejected_steps"] >= 0

