"""The references the suite measures against: the exact linear solution and heyoka's quadruple-precision runs.

1. ``models.analytic.linear_exact`` solves the linear model: its velocity columns are the time derivative of its
   positions, the time derivative of its velocities is the model's numba acceleration, and it starts at the
   release state. (Comparing its velocity columns with RHS(y)[0:2] would test nothing: the first half of the
   right-hand side *is* the velocity part of the state. Both derivatives are therefore taken numerically with
   an 8th-order central difference whose error is bounded below.)
2. heyoka in real128 and in double precision at its default tolerance follow the closed form over one Panthéon
   day.
3. heyoka (double) conserves the spherical model's Jacobi integral over 6 h, and the real128 reference agrees
   with that run to the bound its tolerance implies.
4. On the quadratic drag, whose smoothed speed is nearly singular at every turning point (models/README.md "Drag
   and drive"), the real128 reference agrees with an independent solver, mpmath's Taylor integrator ``odefun``
   at 30 digits over the model's own source, to the rounding of its doubles.
"""

from __future__ import annotations

import types

import mpmath
import numpy as np
import pytest

from foucault_bench.integrators import Problem, get_integrator
from foucault_bench.integrators.methods.heyoka_taylor import REFERENCE_TOLERANCE
from foucault_bench.models import MODELS, PendulumParameters
from foucault_bench.models.analytic import linear_exact

EPS = float(np.finfo(np.float64).eps)
SIDEREAL_DAY_S = 86164.0
PANTHEON = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)

# 8th-order central difference for the first derivative (offsets −4..4; Fornberg, Math. Comp. 51, 699 (1988)).
CENTRAL_WEIGHTS = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
CENTRAL_OFFSETS = np.arange(-4, 5)

LINEAR_CASES = {
    "pantheon": PANTHEON,
    "fast-rotation": PendulumParameters(length_m=1.0, latitude_deg=40.0, amplitude_m=0.2,
                                        earth_rate_rad_s=0.3 * np.sqrt(9.81)),
    "south-oblique": PendulumParameters(length_m=12.2, latitude_deg=-34.1, amplitude_m=1.0, release_azimuth_deg=30.0),
    "equator": PendulumParameters(length_m=22.9, latitude_deg=0.0, amplitude_m=2.0, release_azimuth_deg=200.0),
}


def central_difference_bound(h_omega: float, max_phase_rad: float) -> float:
    """Error bound of the 8th-order central difference of a sum of harmonics of frequency ≤ Ω' (step h),
    relative to (amplitude × Ω'), when the samples carry a phase error of up to ε·(8 + 2Ω't):

    truncation: each harmonic e^{iωt} is differentiated with relative error (ωh)⁸/630 (Taylor expansion of the
    stencil), at most 2·(Ω'h)⁸/630 for the two harmonics of the linear solution (amplitudes ≤ A(1 + a/Ω));
    round-off: Σ|w| × ε(8 + 2Ω't) / (Ω'h), with Σ|w| = 2.084 the stencil's absolute weight sum.
    """
    truncation = 2.0 * h_omega**8 / 630.0
    round_off = np.sum(np.abs(CENTRAL_WEIGHTS)) * EPS * (8.0 + 2.0 * max_phase_rad) / h_omega
    return truncation + round_off


@pytest.mark.parametrize("params", LINEAR_CASES.values(), ids=LINEAR_CASES.keys())
def test_linear_exact_solution_satisfies_the_model_and_the_release(params: PendulumParameters) -> None:
    model = MODELS["linear"]
    k2 = params.gravity_m_s2 / params.length_m
    a = params.vertical_rate_rad_s
    fastest = np.sqrt(k2 + a * a) + abs(a)  # highest angular frequency present: Ω + |a|
    h = 0.05 / fastest
    rng = np.random.default_rng(7)
    t = rng.uniform(0.0, 50 * 2 * np.pi / fastest, 300)
    samples = linear_exact(params, (t[:, None] + h * CENTRAL_OFFSETS[None, :]).ravel()).reshape(t.size, 9, 4)
    derivative = np.einsum("j,tjc->tc", CENTRAL_WEIGHTS, samples) / h
    state = samples[:, 4, :]
    p = params.parameter_vector()
    acceleration = np.array([model.numba_rhs(0.0, row, p)[2:] for row in state])

    bound = central_difference_bound(0.05, fastest * (t.max() + 4 * h))
    amplitude = params.amplitude_m
    velocity_residual = np.max(np.abs(derivative[:, :2] - state[:, 2:])) / (amplitude * fastest)
    acceleration_residual = np.max(np.abs(derivative[:, 2:] - acceleration)) / (amplitude * fastest**2)
    assert velocity_residual <= bound
    assert acceleration_residual <= bound

    np.testing.assert_allclose(linear_exact(params, np.array([0.0]))[0], params.initial_state(),
                               rtol=0.0, atol=4 * EPS * amplitude)


@pytest.fixture(scope="module")
def pantheon_day() -> dict:
    """The linear model over one sidereal day (output every 10 s): closed form, heyoka real128 and double."""
    problem = Problem(MODELS["linear"], PANTHEON, np.linspace(0.0, SIDEREAL_DAY_S, 8617))
    return {
        "exact": linear_exact(PANTHEON, problem.t_out),
        "quad": get_integrator("heyoka_taylor_quad").solve(problem, tol=REFERENCE_TOLERANCE, monitor=False),
        "double": get_integrator("heyoka_taylor").solve(problem, tol=EPS, monitor=False),
    }


@pytest.mark.parametrize(("run", "bound"), [("quad", 1.0e-11), ("double", 1.0e-9)])
def test_heyoka_follows_the_closed_form_over_a_pantheon_day(pantheon_day: dict, run: str, bound: float) -> None:
    """real128: bound 1e-11 of A, set by the closed form itself, whose phase Ωt ≈ 3.3e4 rad is evaluated in
    double precision (ulp 3.6e-12 rad). double at heyoka's default tolerance (machine epsilon): 1e-9."""
    solution = pantheon_day[run]
    assert solution.status == "ok", solution.message
    exact = pantheon_day["exact"]
    k = PANTHEON.pendulum_frequency_rad_s
    assert np.max(np.abs(solution.y[:, :2] - exact[:, :2])) / PANTHEON.amplitude_m <= bound
    assert np.max(np.abs(solution.y[:, 2:] - exact[:, 2:])) / (k * PANTHEON.amplitude_m) <= bound


@pytest.fixture(scope="module")
def spherical_six_hours() -> dict:
    problem = Problem(MODELS["spherical"], PANTHEON, np.linspace(0.0, 6 * 3600.0, 2161))
    return {
        "problem": problem,
        "double": get_integrator("heyoka_taylor").solve(problem, tol=EPS, monitor=False),
        "quad": get_integrator("heyoka_taylor_quad").solve(problem, tol=REFERENCE_TOLERANCE, monitor=False),
    }


def test_heyoka_conserves_the_jacobi_integral_of_the_spherical_model(spherical_six_hours: dict) -> None:
    solution = spherical_six_hours["double"]
    assert solution.status == "ok", solution.message
    energy = MODELS["spherical"].numba_energy
    p = PANTHEON.parameter_vector()
    jacobi = np.array([energy(*row, p) for row in solution.y])
    assert np.max(np.abs(jacobi - jacobi[0])) / abs(jacobi[0]) <= 1.0e-12


def test_quad_reference_agrees_with_the_double_run_to_its_tolerance(spherical_six_hours: dict) -> None:
    """heyoka keeps each step's local error below ε·max(1, |y|∞) = ε·A here (relative mode, A = 3 m > 1);
    without amplification by the flow the global error is at most (steps × ε)·A, the bound used."""
    double, quad = spherical_six_hours["double"], spherical_six_hours["quad"]
    assert quad.status == "ok", quad.message
    bound = double.steps * EPS
    assert np.max(np.abs(double.y[:, :2] - quad.y[:, :2])) / PANTHEON.amplitude_m <= bound
    k = PANTHEON.pendulum_frequency_rad_s
    assert np.max(np.abs(double.y[:, 2:] - quad.y[:, 2:])) / (k * PANTHEON.amplitude_m) <= bound


def test_quad_reference_on_the_quadratic_drag_agrees_with_mpmath() -> None:
    """12 s of the Panthéon's pendulum with the damped model's example drag (c = 1e-3 /m), through the turning
    point at 8.2 s: mpmath's ``odefun`` (its own Taylor steps and step control, 30 digits, tol 1e-28) on the
    model's source over mpmath's functions against the real128 reference, both rounded to doubles. Each rounds
    to within half an ulp of the state, so they differ by at most one ulp of a component, ≤ 2ε of the scale
    (A, A, kA, kA) (measured: equal)."""
    model = MODELS["damped_linear"]
    problem = Problem(model, model.with_example_parameters(PANTHEON), np.linspace(0.0, 12.0, 13))
    reference = get_integrator("heyoka_taylor_quad").solve(problem, tol=REFERENCE_TOLERANCE, monitor=False)
    assert reference.status == "ok", reference.message
    math_namespace = types.SimpleNamespace(sqrt=mpmath.sqrt, sin=mpmath.sin, cos=mpmath.cos)
    with mpmath.workdps(30):
        p = [mpmath.mpf(float(value)) for value in problem.parameter_vector]

        def rhs(t, state):
            return [state[2], state[3], *model.acceleration(math_namespace, *state, p)]

        solution = mpmath.odefun(rhs, 0, [mpmath.mpf(float(value)) for value in problem.initial_state],
                                 tol=mpmath.mpf(10) ** -28)
        independent = np.array([[float(value) for value in solution(t)] for t in problem.t_out])
    k = PANTHEON.pendulum_frequency_rad_s
    scale = PANTHEON.amplitude_m * np.array([1.0, 1.0, k, k])
    assert np.max(np.abs(independent - reference.y) / scale) <= 2 * EPS
