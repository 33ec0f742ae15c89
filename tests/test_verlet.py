"""The rotating-frame Verlet keeps the sphere's invariants and gets the precession right (its symplecticity is
checked with every other declared-symplectic method in ``tests/test_structure.py``). The step-structure tests run
on the linear model and the leaves of the refinement hierarchy (tests/model_sets.py): between them every path of
``verlet_sequences`` (plane or sphere, with or without the velocity-dependent remainder)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from foucault_bench.integrators import Problem, get_integrator
from foucault_bench.integrators.composition import SEQUENCE_SUB_STEPS, VerletComposition
from foucault_bench.integrators.methods.verlet import rotation_coefficients, verlet_parts
from foucault_bench.models import MODELS, PendulumParameters
from foucault_bench.bench.studies import ReleaseAzimuthConfig, precession_vs_release_azimuth
from model_sets import LEAVES_AND_LINEAR

PARIS = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)


def _fitted_precession_rate(turning: np.ndarray) -> float:
    """Least-squares slope of the unwrapped swing azimuth (rad/s); integrators/README.md "Measuring the precession
    rate"."""
    azimuth = np.unwrap(2 * np.arctan2(turning[:, 2], turning[:, 1])) / 2
    return float(np.polyfit(turning[:, 0], azimuth, 1)[0])


def test_verlet_precesses_at_the_textbook_rate_where_rk4_of_equal_cost_does_not() -> None:
    """On the isotropic linear model the rotation and the oscillator commute, so the Verlet orbit's
    orientation turns at exactly −a; only the O((kh)²) interpolation of turning points between steps remains,
    and it oscillates instead of accumulating. RK4 at the same cost (2 evaluations per step against 4, so twice
    the step) is too slow by ≈ (kh)⁴/24 (integrators/README.md "Fixed-step methods on this problem")."""
    period = PARIS.small_swing_period_s
    a = PARIS.vertical_rate_rad_s
    grid = np.linspace(0.0, 200 * period, 201)
    verlet = get_integrator("verlet").solve(Problem(MODELS["linear"], PARIS, grid), step_s=period / 20)
    rk4 = get_integrator("rk4").solve(Problem(MODELS["linear"], PARIS, grid), step_s=period / 10)
    assert verlet.nfev == rk4.nfev
    verlet_error = abs(_fitted_precession_rate(verlet.streamed.turning_points) + a) / a
    rk4_error = abs(_fitted_precession_rate(rk4.streamed.turning_points) + a) / a
    kh_rk4 = PARIS.pendulum_frequency_rad_s * period / 10
    assert rk4_error == pytest.approx(kh_rk4**4 / 24, rel=0.2)
    assert verlet_error < 1e-5 < rk4_error


@pytest.mark.parametrize("centrifugal", [True, False])
def test_verlet_on_the_sphere_keeps_the_jacobi_integral_bounded(centrifugal: bool) -> None:
    """Symplectic: the Jacobi-integral error oscillates at O((kh)²) without secular drift (backward error
    analysis, Hairer, Lubich & Wanner Thm. IX.8.1). Checked: no growth between 2 h and 8 h."""
    params = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=6.0, centrifugal=centrifugal)
    period = params.small_swing_period_s
    h = period / 50

    def max_error(hours: float) -> float:
        duration = round(hours * 3600 / h) * h
        problem = Problem(MODELS["spherical"], params, np.array([0.0, duration]))
        solution = get_integrator("verlet").solve(problem, step_s=h)
        assert solution.status == "ok"
        return solution.streamed.energy_max_rel_error

    short, long = max_error(2.0), max_error(8.0)
    kh = params.pendulum_frequency_rad_s * h
    assert short < kh**2  # O((kh)²) oscillation, relative to the swing's energy
    assert long <= short * 1.05  # no secular growth


def test_verlet_precession_error_on_the_sphere_depends_on_the_release_direction() -> None:
    """A North-South swing feels the horizontal part of ω along its own line: Verlet's precession error is then
    about 0.09·θ₀ cos φ·Ω_E·(kh)² (measured 1.03× that at kh = 0.025): second order, so halving kh from 0.05
    quarters it (±15 %; the next term still shows at larger steps, 2.8× from 0.4 to 0.2), and at least 10× the
    error of an East release at the same kh (measured ~70×). Rates from the grid against heyoka at tol 1e-15,
    whose own error and the measurement's floor are ~1e-11 of Ω_E, far below."""
    config = ReleaseAzimuthConfig(latitudes_deg=(40.44,), azimuths_deg=(0.0, 90.0), duration_s=300.0,
                                  integrators=("verlet",))
    errors = {}
    for kh in (0.05, 0.025):
        table = precession_vs_release_azimuth(dataclasses.replace(config, kh=kh), progress=False)
        errors[kh] = dict(zip(table["release_azimuth_deg"], table["error_earth"], strict=True))
    assert errors[0.05][0.0] / errors[0.025][0.0] == pytest.approx(4.0, rel=0.15)
    for kh in errors:
        assert errors[kh][0.0] >= 10 * errors[kh][90.0]


@pytest.mark.parametrize("model", LEAVES_AND_LINEAR)
@pytest.mark.parametrize("name", ["yoshida4", "composition6", "composition8", "composition10"])
def test_a_composition_step_is_its_verlet_sub_steps_in_a_row(model: str, name: str) -> None:
    """A composition step merges the half rotations of neighbouring sub-steps and stays in canonical variables
    (``verlet_sequences``); it must be the same map as the Verlet steps γ₁h, …, γₛh taken one after the other,
    to round-off. Released off-axis with a sideways velocity, so that every component of the state moves."""
    composition = get_integrator(name)
    step = composition.compiled_step(MODELS[model])
    verlet = get_integrator("verlet").compiled_step(MODELS[model])
    p = tuple(PARIS.parameter_vector())
    h = 0.3 / PARIS.pendulum_frequency_rad_s
    state = (2.0, 1.5, 0.1, -0.2)
    in_a_row = state
    for gamma in composition.composition.weights:
        in_a_row = verlet(*in_a_row, gamma * h, p)
    composed = step(*state, h, p)
    scale = np.array([3.0, 3.0, 3.0 * PARIS.pendulum_frequency_rad_s, 3.0 * PARIS.pendulum_frequency_rad_s])
    assert np.all(np.abs(np.subtract(composed, in_a_row)) <= 1e-14 * scale)


@pytest.mark.parametrize("model", LEAVES_AND_LINEAR)
@pytest.mark.parametrize("name", ["verlet", "yoshida4", "composition6", "composition8", "composition10"])
def test_the_sub_step_loop_is_the_sub_steps_written_out(model: str, name: str) -> None:
    """The compiled step runs one sub-step body in a loop over a table of rotations and sub-step sizes computed
    once per run (``verlet_sequences``); it must compute bitwise what the sub-steps give written out one by one,
    each rotation computed where it is used: per sequence of ``SEQUENCE_SUB_STEPS``, the change to canonical
    variables, the merged rotations R(c_i h) between kick–drift–kicks of γ_i h, and the change back. Checked for
    the step alone (its table computed at each call) and for three steps of the fixed-step loop."""
    integrator = get_integrator(name)
    weights = integrator.composition.weights if isinstance(integrator, VerletComposition) else (1.0,)
    parts = verlet_parts(MODELS[model], getattr(integrator, "remainder_sweeps", 2))
    p = tuple(PARIS.parameter_vector())
    h = 0.3 / PARIS.pendulum_frequency_rad_s

    def written_out(x: float, y: float, vx: float, vy: float) -> tuple[float, float, float, float]:
        for first in range(0, len(weights), SEQUENCE_SUB_STEPS):
            sequence = weights[first:first + SEQUENCE_SUB_STEPS]
            coefficients = rotation_coefficients(sequence)
            q = parts.to_canonical(x, y, vx, vy, p)
            for gamma, c in zip(sequence, coefficients[:-1], strict=True):
                q = parts.kick_drift_kick(parts.turn(parts.rotation(c, h, p), q), gamma * h, p)
            x, y, vx, vy = parts.from_canonical(parts.turn(parts.rotation(coefficients[-1], h, p), q), p)
        return x, y, vx, vy

    state = (2.0, 1.5, 0.1, -0.2)
    expected = [state]
    for _ in range(3):
        expected.append(written_out(*expected[-1]))
    assert np.array(integrator.compiled_step(MODELS[model])(*state, h, p)).tobytes() == np.array(expected[1]).tobytes()
    out = np.full((4, 4), np.nan)
    integrator.kernel(MODELS[model])(np.array(state), PARIS.parameter_vector(), h, 3, 1, out, False, np.empty((0, 3)),
                                     1e3 * PARIS.length_m)
    assert out.tobytes() == np.array(expected).tobytes()
