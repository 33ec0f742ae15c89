"""Every adaptive integrator on the linear model and the leaves of the refinement hierarchy at their example
parameters, the other models of ``ADAPTIVE_MODELS`` and ``REFINED_MODELS`` on one integrator per way of reaching
the right-hand side (``ideal_cases``, ``refined_cases``: each integrator × model pair is one more compilation):
runs, accuracy against the real128 reference, counters, turning points, failures and settings.

Scene: the Panthéon pendulum (L = 67 m, φ = 48.846°, A = 3 m) for 120 s (7 swings, 14 turning points), output
every second. Errors are max over the grid of |Δy_i| / scale_i with scale = (A, A, kA, kA). Thresholds and the
measurements behind them (this machine, tol = 1e-10 unless said):

* error shrinks by ≥ 100× from tol = 1e-6 to 1e-10 (tolerance proportionality would give 1e4; the multistep and
  Taylor controllers are not proportional; smallest measured ratio 1.75e3, cvode_adams on the spherical model);
* error ≤ 1e4 × tol at tol = 1e-10: the tolerance bounds the local error per step, the global error adds up over
  the steps (largest measured 1.7e3 × tol, cvode_bdf on the linear model: a margin of 5.9);
* turning points, located on the output grid by the suite's one procedure
  (``bench.problems.turning_points.turning_points_from_grid``) for the solution and for the reference alike:
  times within (10 × error + 1e-13)/k and positions within (10 × error + 1e-13)·A of the reference's; measured
  ≤ 1.0 × error where the error is above round-off, and ≤ 2e-14 where it is not (1e-13: double round-off of a
  turning time near t = 100 s, k·t·ε ≈ 1e-14, with a margin of 10). Against the exact linear solution the
  grid interpolation's own error bounds are added (``turning_time_error_bound``, ``azimuth_error_bound``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import sys

import numpy as np
import pytest

from foucault_bench.integrators import REGISTRY, Problem, Solution, built_in_names, get_integrator
from foucault_bench.integrators.adaptive import state_scale
from foucault_bench.bench.problems.turning_points import (
    azimuth_error_bound,
    grid_accelerations,
    turning_points_from_grid,
    turning_time_error_bound,
)
from foucault_bench.integrators.embedded_rk import EmbeddedRungeKutta
from foucault_bench.integrators.methods.cvode import CvodeAdams, CvodeBdf, CvodeIntegrator
from foucault_bench.integrators.methods.cvode_py import CvodeAdamsPy, CvodeBdfPy
from foucault_bench.integrators.methods.dopri5 import Dopri5
from foucault_bench.integrators.methods.heyoka_taylor import REFERENCE_TOLERANCE, HeyokaTaylor, _compiled_template
from foucault_bench.integrators.methods.scipy_ivp import ScipyRk45
from foucault_bench.models import MODELS, Model, PendulumParameters
from foucault_bench.models.analytic import linear_exact, textbook_turning_azimuth
from foucault_bench.models.parameters import P_K2, P_LENGTH
from model_sets import refinement_leaves

ADAPTIVE = [name for name in built_in_names() if REGISTRY[name].adaptive]
SCENE = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
T_OUT = np.linspace(0.0, 120.0, 121)
LOOSE, TIGHT = 1.0e-6, 1.0e-10
SHRINK_FACTOR = 100.0
GLOBAL_OVER_LOCAL = 1.0e4
TURNING_POINT_MARGIN, ROUND_OFF_FLOOR = 10.0, 1.0e-13
def rhs_calls_per_step_at_least(name: str) -> int:
    """New right-hand-side calls per accepted step, from what the integrator declares: an explicit Runge-Kutta
    pair's stages (``tableau.stages`` of a compiled pair, ``n_stages`` of scipy's solver class; first same as
    last: the last stage is the next step's first), else 1."""
    integrator = get_integrator(name)
    if isinstance(integrator, EmbeddedRungeKutta):
        return integrator.tableau.stages
    return getattr(getattr(integrator, "solver_class", None), "n_stages", 1)


@functools.cache
def run(name: str, model_name: str, tol: float) -> Solution:
    return get_integrator(name).solve(Problem(MODELS[model_name], SCENE, T_OUT), tol=tol)


@functools.cache
def reference(model_name: str) -> Solution:
    solution = run("heyoka_taylor_quad", model_name, REFERENCE_TOLERANCE)
    assert solution.status == "ok", solution.message
    return solution


def scaled_error(solution: Solution, model_name: str) -> float:
    return float(np.max(np.abs(solution.y - reference(model_name).y) / state_scale(SCENE)))


def grid_turning_points(solution: Solution, model_name: str) -> np.ndarray:
    """Turning points (t > 0) of ``solution`` located on its output grid, as the verdicts locate them."""
    accelerations = grid_accelerations(MODELS[model_name], SCENE, solution.y)
    return turning_points_from_grid(solution.t, solution.y, accelerations, include_release=False)


ADAPTIVE_MODELS = ("linear", "seed_planar", "spherical")
"""The models the adaptive drivers are run on here at this module's scene: the three ideal ones (one per kind of
right-hand side: linear, velocity-dependent planar, constrained spherical). The real-pendulum models refine them
with force terms that are zero at the Panthéon's parameters (no anisotropy, drag or drive): they are run at their
declared example parameters instead (``REFINED_MODELS``), where those terms act; their right-hand sides are also
checked against heyoka's there (tests/test_heyoka_rhs.py) and their order on the fixed-step integrators
(tests/test_selftest.py)."""
REFINED_MODELS = tuple(name for name in MODELS if name not in ADAPTIVE_MODELS)
"""The real-pendulum models (an anisotropic support, drag, a drive), each run at ``Model.with_example_parameters``
of this module's scene."""
REFINED_LEAVES = tuple(name for name in REFINED_MODELS if name in refinement_leaves())
"""The real-pendulum models no other model refines: each carries the force terms of the models it refines (the
drive model its parent's drag), so every adaptive integrator is run on these, and the others on
``FORCE_ACCESS_REPRESENTATIVES`` (one integrator × model product fewer to compile)."""
FORCE_ACCESS_REPRESENTATIVES = ("dopri5", "cvode_bdf", "scipy_rk45", "heyoka_taylor")
"""One adaptive integrator per way of reaching a model's right-hand side: the compiled acceleration inlined into
a numba driver (dopri5, like every embedded pair, Nyström pair and extrapolation), the compiled right-hand side
and Jacobian called by SUNDIALS (cvode_bdf), the compiled right-hand side called from Python (scipy_rk45) and the
model's expression system compiled by heyoka (heyoka_taylor)."""


def test_the_library_drivers_are_discovered() -> None:
    drivers = (CvodeAdams, CvodeAdamsPy, HeyokaTaylor, ScipyRk45, Dopri5)  # one integrator of each driver module
    assert {driver.name for driver in drivers} <= set(ADAPTIVE)


def test_the_rhs_calls_per_step_follow_the_declared_stages() -> None:
    assert [rhs_calls_per_step_at_least(name) for name in ("scipy_rk45", "dopri5", "scipy_dop853", "dop853")] == [
        6, 6, 12, 12]  # Dormand & Prince 1980 (6 stages, FSAL); DOP853: 12 stages (Hairer's dop853.f)
    assert rhs_calls_per_step_at_least("cvode_bdf") == 1


@pytest.mark.parametrize("name", ADAPTIVE)
def test_declares_its_facts(name: str) -> None:
    integrator = get_integrator(name)
    assert integrator.adaptive is True and integrator.stages is None
    assert integrator.order is None or (isinstance(integrator.order, int) and integrator.order > 0)
    assert integrator.family and integrator.reference
    documentation = ((type(integrator).__doc__ or "") + (sys.modules[type(integrator).__module__].__doc__ or ""))
    for fact in ("order", "stab", "tolerance"):  # order, stability notes, tolerance mapping
        assert fact in documentation.lower(), fact


def ideal_cases() -> list:
    """(integrator, model) for every adaptive integrator on the linear model, and the other ideal models on
    ``FORCE_ACCESS_REPRESENTATIVES`` (every integrator meets their geometry and forces again in the leaves of
    ``refined_cases``, which refine them)."""
    return [pytest.param(name, model_name, id=f"{name}-{model_name}")
            for model_name in ADAPTIVE_MODELS for name in ADAPTIVE
            if model_name == "linear" or name in FORCE_ACCESS_REPRESENTATIVES]


@pytest.mark.parametrize("name, model_name", ideal_cases())
def test_runs_with_consistent_counters(name: str, model_name: str) -> None:
    solution = run(name, model_name, TIGHT)
    assert solution.status == "ok" and solution.message == "", solution.message
    assert np.all(np.isfinite(solution.y))
    np.testing.assert_allclose(solution.y[0], SCENE.initial_state(), rtol=0, atol=1e-15 * SCENE.amplitude_m)
    assert solution.tolerance == TIGHT
    assert isinstance(solution.nfev, int) and solution.nfev > 0
    assert solution.njev is None or solution.njev >= 0
    assert solution.rejected_steps is None or solution.rejected_steps >= 0
    if solution.steps is not None:
        assert 0 < solution.steps <= solution.nfev
        assert solution.nfev >= rhs_calls_per_step_at_least(name) * solution.steps
    family = type(get_integrator(name))
    if issubclass(family, HeyokaTaylor):  # one Taylor expansion per step, never rejected
        assert solution.nfev == solution.steps and solution.rejected_steps == 0
    if issubclass(family, CvodeIntegrator):  # Newton iteration with the analytic Jacobian
        assert 1 <= solution.njev < solution.nfev


@pytest.mark.parametrize("name, model_name", ideal_cases())
def test_error_against_the_reference_shrinks_with_the_tolerance(name: str, model_name: str) -> None:
    loose = scaled_error(run(name, model_name, LOOSE), model_name)
    tight = scaled_error(run(name, model_name, TIGHT), model_name)
    assert tight <= loose / SHRINK_FACTOR, (loose, tight)
    assert tight <= GLOBAL_OVER_LOCAL * TIGHT


@functools.cache
def refined_run(name: str, model_name: str, tol: float) -> Solution:
    """``name`` on the real-pendulum model ``model_name`` at its example parameters (the scene's pendulum)."""
    model = MODELS[model_name]
    return get_integrator(name).solve(Problem(model, model.with_example_parameters(SCENE), T_OUT), tol=tol)


def refined_cases() -> list:
    """(integrator, model) for every adaptive integrator and real-pendulum model that no other refines, and every
    other real-pendulum model on ``FORCE_ACCESS_REPRESENTATIVES``."""
    return [pytest.param(name, model_name, id=f"{name}-{model_name}")
            for model_name in REFINED_MODELS for name in ADAPTIVE
            if model_name in REFINED_LEAVES or name in FORCE_ACCESS_REPRESENTATIVES]


@pytest.mark.parametrize("name, model_name", refined_cases())
def test_the_real_pendulum_models_run_and_converge_on_every_adaptive_integrator(name: str, model_name: str) -> None:
    """Each adaptive integrator on each real-pendulum model where its terms act: an ok run with its counters, and
    an error against the real128 reference that shrinks with the tolerance by the same factors as on the ideal
    models (the refinements add smooth force terms: drag, a drive, a stiffer axis; no new stiffness at these
    parameters), so a driver that mishandles a refined model's right-hand side or Jacobian fails here."""
    assert not MODELS[model_name].equals_parents_at(MODELS[model_name].with_example_parameters(SCENE))
    reference_solution = refined_run("heyoka_taylor_quad", model_name, REFERENCE_TOLERANCE)
    assert reference_solution.status == "ok", reference_solution.message
    errors = {}
    for tol in (LOOSE, TIGHT):
        solution = refined_run(name, model_name, tol)
        assert solution.status == "ok" and solution.message == "", solution.message
        assert solution.tolerance == tol and isinstance(solution.nfev, int) and solution.nfev > 0
        if solution.steps is not None:
            assert 0 < solution.steps <= solution.nfev
        errors[tol] = float(np.max(np.abs(solution.y - reference_solution.y) / state_scale(SCENE)))
    assert errors[TIGHT] <= errors[LOOSE] / SHRINK_FACTOR, errors
    assert errors[TIGHT] <= GLOBAL_OVER_LOCAL * TIGHT, errors


@pytest.mark.parametrize("model_name", sorted(MODELS))
def test_the_taylor_step_watch_only_adds_a_variable(model_name: str) -> None:
    """heyoka's Taylor system is the model's system, plus one watched variable for a model with a step watch."""
    model = MODELS[model_name]
    system, taylor_system = model.heyoka_system(), model.heyoka_taylor_system()
    assert [str(pair) for pair in taylor_system[:4]] == [str(pair) for pair in system]
    assert len(taylor_system) == 4 + (model.taylor_step_watch is not None)


@pytest.mark.parametrize("model_name", ["damped_linear", "driven_linear"])
def test_the_taylor_step_watch_changes_nothing_without_quadratic_drag_and_controls_it_with(model_name: str) -> None:
    """The quadratic drag's step watch (``Model.taylor_step_watch``) is identically zero without quadratic drag:
    the watched runs are then bitwise those of the unwatched model (steps included). With it (the damped model's
    example parameters, c = 1e-3 /m) the unwatched run is the uncontrolled one (measured 1.6e-5 of the swing at
    tol 1e-10 with events, 1.5e-4 without) and the watched one is within ``GLOBAL_OVER_LOCAL`` × tol of the
    reference (measured 3.8e-15), so the watch is what controls the error there."""
    model = MODELS[model_name]
    unwatched = dataclasses.replace(model, taylor_step_watch=None)
    without_drag = model.with_example_parameters(SCENE)
    assert without_drag.drag_quadratic_per_m == 0.0 or model_name == "damped_linear"
    without_drag = dataclasses.replace(without_drag, drag_quadratic_per_m=0.0)
    watched_run = get_integrator("heyoka_taylor").solve(Problem(model, without_drag, T_OUT), tol=TIGHT)
    unwatched_run = get_integrator("heyoka_taylor").solve(Problem(unwatched, without_drag, T_OUT), tol=TIGHT)
    assert np.array_equal(watched_run.y, unwatched_run.y) and watched_run.steps == unwatched_run.steps
    if model_name == "damped_linear":
        with_drag = model.with_example_parameters(SCENE)
        reference_y = refined_run("heyoka_taylor_quad", model_name, REFERENCE_TOLERANCE).y
        unwatched_run = get_integrator("heyoka_taylor").solve(Problem(unwatched, with_drag, T_OUT), tol=TIGHT)
        errors = [float(np.max(np.abs(solution.y - reference_y) / state_scale(SCENE)))
                  for solution in (refined_run("heyoka_taylor", model_name, TIGHT), unwatched_run)]
        assert errors[0] <= GLOBAL_OVER_LOCAL * TIGHT < errors[1], errors


@pytest.mark.parametrize("name, model_name", ideal_cases())
def test_turning_points_match_the_reference(name: str, model_name: str) -> None:
    solution = run(name, model_name, TIGHT)
    expected = grid_turning_points(reference(model_name), model_name)
    found = grid_turning_points(solution, model_name)
    assert found.shape == expected.shape == (14, 3)
    assert np.all(found[:, 0] > 0.0) and np.all(np.diff(found[:, 0]) > 0.0)
    bound = TURNING_POINT_MARGIN * scaled_error(solution, model_name) + ROUND_OFF_FLOOR
    k = SCENE.pendulum_frequency_rad_s
    assert np.max(np.abs(found[:, 0] - expected[:, 0])) * k <= bound
    assert np.max(np.abs(found[:, 1:] - expected[:, 1:])) / SCENE.amplitude_m <= bound


@pytest.mark.parametrize("name", ADAPTIVE)
def test_linear_turning_points_lie_on_the_textbook_azimuth(name: str) -> None:
    """Exact linear solution: turning points at t_n = nπ/Ω on azimuth ψ₀ − a t_n (mod π), models/README.md "Closed
    forms"."""
    solution = run(name, "linear", TIGHT)
    found = grid_turning_points(solution, "linear")
    big_omega = math.sqrt(SCENE.gravity_m_s2 / SCENE.length_m + SCENE.vertical_rate_rad_s**2)
    n = np.arange(1, found.shape[0] + 1)
    assert found.shape[0] == math.floor(T_OUT[-1] * big_omega / math.pi)
    error = float(np.max(np.abs(solution.y - linear_exact(SCENE, T_OUT)) / state_scale(SCENE)))
    bound = TURNING_POINT_MARGIN * error + ROUND_OFF_FLOOR
    interval_s = float(T_OUT[1] - T_OUT[0])
    time_bound = bound + turning_time_error_bound(SCENE, interval_s, float(T_OUT[-1])) * big_omega
    assert np.max(np.abs(found[:, 0] - n * math.pi / big_omega)) * big_omega <= time_bound
    azimuth = np.arctan2(found[:, 2], found[:, 1])
    offset = (azimuth - textbook_turning_azimuth(SCENE, found[:, 0]) + math.pi / 2) % math.pi - math.pi / 2
    assert np.max(np.abs(offset)) <= bound + azimuth_error_bound(SCENE, interval_s, float(T_OUT[-1]))


@pytest.mark.parametrize("name", ADAPTIVE)
def test_output_grid_may_start_after_the_release(name: str) -> None:
    """Two output times, the first after t = 0: CVODE gets a midpoint, heyoka propagates to t_out[0] first."""
    t_out = np.array([5.0, 120.0])
    solution = get_integrator(name).solve(Problem(MODELS["linear"], SCENE, t_out), tol=TIGHT)
    assert solution.status == "ok", solution.message
    assert solution.y.shape == (2, 4)
    error = np.max(np.abs(solution.y - linear_exact(SCENE, t_out)) / state_scale(SCENE))
    assert error <= GLOBAL_OVER_LOCAL * TIGHT


@pytest.mark.parametrize("name", ADAPTIVE)
def test_runs_are_deterministic(name: str) -> None:
    first = run(name, "spherical", TIGHT)
    again = get_integrator(name).solve(Problem(MODELS["spherical"], SCENE, T_OUT), tol=TIGHT)
    np.testing.assert_array_equal(again.y, first.y)
    assert (again.streamed is None) == (first.streamed is None)
    if first.streamed is not None:
        np.testing.assert_array_equal(again.streamed.turning_points, first.streamed.turning_points)
    assert (again.nfev, again.njev, again.steps) == (first.nfev, first.njev, first.steps)


@pytest.mark.parametrize("name", ADAPTIVE)
@pytest.mark.parametrize("bad", [None, 0.0, -1e-8, 1.0, 2.0, float("nan"), "1e-8"])
def test_bad_tolerance_raises(name: str, bad) -> None:
    with pytest.raises(ValueError):
        get_integrator(name).solve(Problem(MODELS["linear"], SCENE, T_OUT), tol=bad)


@pytest.mark.parametrize("name", ADAPTIVE)
def test_step_size_is_refused(name: str) -> None:
    with pytest.raises(ValueError, match="adaptive"):
        get_integrator(name).solve(Problem(MODELS["linear"], SCENE, T_OUT), step_s=0.01, tol=TIGHT)


@pytest.mark.parametrize("name", ["scipy_dop853", "scipy_rk45", "scipy_lsoda"])
def test_scipy_refuses_tolerances_it_would_silently_raise(name: str) -> None:
    with pytest.raises(ValueError, match="floor"):
        get_integrator(name).solve(Problem(MODELS["linear"], SCENE, T_OUT), tol=1e-15)


# --- failures -----------------------------------------------------------------------------------------------

def blow_up_force(m, x, y, z, vx, vy, vz, p):
    """ÿ = k²y²/L, ẍ = 0: from y(0) = A at rest, y reaches infinity at t* = 2.4286·√(3L/(2k²A))
    (energy ½ẏ² = k²(y³ − A³)/(3L); ∫₁^∞ du/√(u³ − 1) = 2.4286). No integrator can pass t*."""
    return 0.0 * x, p[P_K2] * y * y / p[P_LENGTH], 0.0 * z


def blow_up_energy(m, x, y, vx, vy, p):
    return 0.5 * (vx * vx + vy * vy) - p[P_K2] * y * y * y / (3.0 * p[P_LENGTH])


BLOW_UP = Model(name="test_blow_up", title="finite-time blow-up (test only)", geometry="plane",
                free_force=blow_up_force, energy=blow_up_energy, energy_name="½|v|² − k²y³/3L",
                conserves_energy=True, hamiltonian=False)
BLOW_UP_SCENE = PendulumParameters(length_m=1.0, latitude_deg=45.0, amplitude_m=0.5)
BLOW_UP_TIME_S = 2.4286 * math.sqrt(3.0 / (2.0 * 9.81 * 0.5))  # 1.343 s


@pytest.mark.parametrize("name", ADAPTIVE)
def test_impossible_problem_returns_a_failed_row_without_raising(name: str) -> None:
    t_out = np.linspace(0.0, 3.0, 31)
    solution = get_integrator(name).solve(Problem(BLOW_UP, BLOW_UP_SCENE, t_out), tol=1e-8)
    assert solution.status in ("failed", "diverged")
    assert solution.message
    assert np.all(np.isfinite(solution.y[t_out < BLOW_UP_TIME_S - 0.05]))
    assert np.all(np.isnan(solution.y[t_out > BLOW_UP_TIME_S + 0.05]))


def step_limit_option(cls: type) -> str:
    return "max_num_steps" if issubclass(cls, CvodeIntegrator) else "max_steps"


@pytest.mark.parametrize("name", ADAPTIVE)
def test_step_limit_gives_a_failed_row_with_the_library_message(name: str) -> None:
    cls = type(get_integrator(name))
    integrator = cls(**{step_limit_option(cls): 10})
    solution = integrator.solve(Problem(MODELS["spherical"], SCENE, T_OUT), tol=TIGHT)
    assert solution.status == "failed"
    assert any(word in solution.message for word in ("max_num_steps", "step_limit", "step limit")), solution.message
    assert np.all(np.isfinite(solution.y[0])) and np.all(np.isnan(solution.y[-1]))


@pytest.mark.parametrize("cls", [CvodeAdams, CvodeBdf, CvodeAdamsPy, CvodeBdfPy, HeyokaTaylor, ScipyRk45, Dopri5])
def test_non_positive_step_limits_are_refused(cls: type) -> None:
    with pytest.raises(ValueError):
        cls(**{step_limit_option(cls): 0})


@pytest.mark.parametrize("cls", [CvodeAdams, CvodeAdamsPy])
def test_sundials_messages_do_not_reach_the_terminal(cls: type, capfd: pytest.CaptureFixture) -> None:
    problem = Problem(MODELS["linear"], SCENE, T_OUT)
    integrator = cls(max_num_steps=10)
    integrator._solve(problem, step_s=None, tol=TIGHT, monitor=False)  # unsilenced: SUNDIALS writes to stderr
    captured = capfd.readouterr()
    assert "CVode" in captured.out + captured.err
    solution = integrator.solve(problem, tol=TIGHT)
    assert solution.status == "failed"
    captured = capfd.readouterr()
    assert captured.out + captured.err == ""


@pytest.mark.parametrize("cls", [CvodeAdams, CvodeBdf, CvodeAdamsPy, CvodeBdfPy])
def test_cvode_runs_with_its_difference_quotient_jacobian(cls: type) -> None:
    solution = cls(analytic_jacobian=False).solve(Problem(MODELS["spherical"], SCENE, T_OUT), tol=TIGHT)
    assert solution.status == "ok", solution.message
    assert solution.njev >= 1 and solution.nfev > 4 * solution.njev
    assert scaled_error(solution, "spherical") <= GLOBAL_OVER_LOCAL * TIGHT


def test_heyoka_reuses_its_compiled_integrator_without_changing_it() -> None:
    problem = Problem(MODELS["seed_planar"], SCENE, T_OUT)
    get_integrator("heyoka_taylor").solve(problem, tol=3e-9)
    compiled = _compiled_template.cache_info().misses
    again = get_integrator("heyoka_taylor").solve(problem, tol=3e-9)
    assert _compiled_template.cache_info().misses == compiled  # nothing compiled again
    assert again.status == "ok"
    template = _compiled_template(MODELS["seed_planar"], "double", 3e-9, True)
    assert float(template.time) == 0.0 and not np.any(template.state)
    assert template.nt_events[0].callback.rows == []
