"""Fixed-step schemes: observed convergence order, linear stability limits, Euler's energy growth, streaming.

Theory (PHYSICS.md "Integrators"; Hairer, Nørsett & Wanner, Solving ODEs I, §IV.2): on ẍ = −k²x explicit
Euler multiplies the energy by exactly (1 + (kh)²) per step; RK4 is stable for kh ≤ 2√2; Störmer–Verlet for
kh < 2. At the equator the linear model has a = Ω_E sin 0 = 0 and is exactly that oscillator (in 2-D).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from foucault_bench.integrators import REGISTRY, FixedStepIntegrator, Problem, get_integrator
from foucault_bench.models import MODELS, PendulumParameters
from foucault_bench.models.analytic import linear_exact

FIXED_STEP = sorted(name for name, integ in REGISTRY.items() if isinstance(integ, FixedStepIntegrator))
PARIS = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
EQUATOR = PendulumParameters(length_m=67.0, latitude_deg=0.0, amplitude_m=3.0)

# Fit window for observed orders: errors (relative to the amplitude) between round-off (well above 1e-12, so
# that accumulated round-off ~1e-14·steps stays negligible) and the pre-asymptotic regime (below 3e-2, where
# the next term of the error expansion is a few % of the leading one at most).
FIT_WINDOW = (1e-11, 3e-2)
ORDER_TOLERANCE = 0.15


def _final_error(integrator_name: str, params: PendulumParameters, model: str, n_steps: int,
                 periods: float, reference: np.ndarray) -> float:
    duration = periods * params.small_swing_period_s
    problem = Problem(MODELS[model], params, np.array([0.0, duration]))
    solution = get_integrator(integrator_name).solve(problem, step_s=duration / n_steps)
    assert solution.status == "ok", solution.message
    return float(np.hypot(*(solution.y[-1, :2] - reference[:2])) / params.amplitude_m)


def observed_order(step_sizes: np.ndarray, errors: np.ndarray) -> float:
    """Least-squares slope of log(error) against log(h) over the points inside FIT_WINDOW."""
    keep = (errors > FIT_WINDOW[0]) & (errors < FIT_WINDOW[1])
    assert keep.sum() >= 3, f"fewer than 3 points in the fit window: {errors}"
    return float(np.polyfit(np.log(step_sizes[keep]), np.log(errors[keep]), 1)[0])


def _reference_final_state(params: PendulumParameters, model: str, periods: float) -> np.ndarray:
    """Linear model: the closed form. Other models: RK4 with a step 16× finer than the finest in the sweep
    (its error (kh)⁴ is then ≥ 16⁴ = 65536× below RK4's finest point, far below every fitted error)."""
    duration = periods * params.small_swing_period_s
    if model == "linear":
        return linear_exact(params, np.array([duration]))[0]
    problem = Problem(MODELS[model], params, np.array([0.0, duration]))
    solution = get_integrator("rk4").solve(problem, step_s=duration / 2**17)
    return solution.y[-1]


SWEEPS = {  # steps per period: powers of two chosen so that ≥ 3 points fall in the fit window
    "explicit_euler": 2 ** np.arange(10, 17),
    "symplectic_euler": 2 ** np.arange(8, 15),
    "rk4": 2 ** np.arange(4, 10),
    "verlet": 2 ** np.arange(5, 12),
    "boris": 2 ** np.arange(5, 12),
    "implicit_midpoint": 2 ** np.arange(5, 12),
    "yoshida4": 2 ** np.arange(4, 10),
    "gauss_legendre4": 2 ** np.arange(3, 9),
    "composition6": 2 ** np.arange(3, 8),
}


@pytest.mark.parametrize("model", sorted(MODELS))
@pytest.mark.parametrize("integrator_name", FIXED_STEP)
def test_observed_order_matches_declared_order(integrator_name: str, model: str) -> None:
    periods = 1.125  # kt = 2.25π: neither a turning point nor a zero crossing, where the phase (resp. the
    # amplitude) error would be hidden and a higher order observed
    params = PendulumParameters(length_m=3.0, latitude_deg=40.44, amplitude_m=0.3)
    reference = _reference_final_state(params, model, periods)
    steps_per_period = SWEEPS[integrator_name]
    errors = np.array([_final_error(integrator_name, params, model, int(n * periods), periods, reference)
                       for n in steps_per_period])
    order = observed_order(params.small_swing_period_s / steps_per_period, errors)
    assert abs(order - get_integrator(integrator_name).order) <= ORDER_TOLERANCE, (order, errors)


def _energy_growth(integrator_name: str, kh: float, n_steps: int, params: PendulumParameters = EQUATOR):
    k = params.pendulum_frequency_rad_s
    h = kh / k
    problem = Problem(MODELS["linear"], params, np.array([0.0, n_steps * h]))
    return get_integrator(integrator_name).solve(problem, step_s=h)


@pytest.mark.parametrize("integrator_name", ["rk4", "verlet", "symplectic_euler"])
def test_stable_just_below_the_limit_and_diverging_just_above(integrator_name: str) -> None:
    limit = get_integrator(integrator_name).stability_limit_kh
    below = _energy_growth(integrator_name, limit * 0.99, 20_000)
    below_longer = _energy_growth(integrator_name, limit * 0.99, 40_000)
    assert below.status == below_longer.status == "ok"
    # bounded: the energy error reached in 20,000 steps does not grow over the next 20,000
    assert below_longer.streamed.energy_max_rel_error <= below.streamed.energy_max_rel_error * (1 + 1e-6)
    above = _energy_growth(integrator_name, limit * 1.01, 20_000)
    assert above.status == "diverged", above.streamed


def test_explicit_euler_energy_grows_as_one_plus_kh_squared_to_the_n() -> None:
    for params in (EQUATOR, PARIS):
        for kh, n_steps in ((0.01, 20_000), (0.1, 500)):
            solution = _energy_growth("explicit_euler", kh, n_steps, params)
            growth = 1.0 + solution.streamed.energy_max_rel_error  # energy grows monotonically
            expected = (1.0 + kh * kh) ** n_steps
            assert abs(growth / expected - 1.0) < 0.01, (params.latitude_deg, kh, growth, expected)
            assert solution.streamed.energy_drift_per_s > 0


def test_explicit_euler_with_a_large_step_is_reported_diverged_not_raised() -> None:
    solution = _energy_growth("explicit_euler", 1.0, 200_000)
    assert solution.status == "diverged"
    assert "diverged after" in solution.message
    assert solution.steps < 200_000


@pytest.mark.parametrize("integrator_name", FIXED_STEP)
def test_output_grid_stride_and_counters(integrator_name: str) -> None:
    """The output rows are the states at the grid times: the same as a run that ends there."""
    period = PARIS.small_swing_period_s
    grid = np.linspace(0.0, 4 * period, 9)
    problem = Problem(MODELS["linear"], PARIS, grid)
    solution = get_integrator(integrator_name).solve(problem, step_s=period / 100)
    assert solution.steps == 400 and solution.step_size_s == pytest.approx(period / 100, rel=1e-12)
    stages = get_integrator(integrator_name).stages  # None: evaluations vary per step and are not counted
    assert solution.nfev == (None if stages is None else stages * 400)
    short = get_integrator(integrator_name).solve(Problem(MODELS["linear"], PARIS, grid[:5]), step_s=period / 100)
    np.testing.assert_array_equal(solution.y[:5], short.y)


def test_turning_points_are_streamed_on_the_textbook_azimuth() -> None:
    """RK4 on the linear model: turning points every half period on azimuth ψ₀ − a t (PHYSICS.md)."""
    period = PARIS.small_swing_period_s
    problem = Problem(MODELS["linear"], PARIS, np.linspace(0.0, 50 * period, 51))
    solution = get_integrator("rk4").solve(problem, step_s=period / 400)
    turning = solution.streamed.turning_points
    assert len(turning) == 100  # one per half period (t = 0 not counted)
    azimuth = np.arctan2(turning[:, 2], turning[:, 1])
    expected = math.pi / 2 - PARIS.vertical_rate_rad_s * turning[:, 0]
    assert np.max(np.abs(np.angle(np.exp(2j * (azimuth - expected))) / 2)) < 1e-7


def test_bad_settings_raise_value_error_before_running() -> None:
    problem = Problem(MODELS["linear"], PARIS, np.linspace(0.0, 10.0, 3))
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="step size"):
            get_integrator("rk4").solve(problem, step_s=bad)
    with pytest.raises(ValueError, match="tolerance"):
        get_integrator("rk4").solve(problem, tol=1e-6)
    with pytest.raises(ValueError, match="uniform output grid"):
        get_integrator("rk4").solve(Problem(MODELS["linear"], PARIS, np.array([0.0, 1.0, 3.0])), step_s=0.1)
