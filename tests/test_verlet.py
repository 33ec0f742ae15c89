"""The rotating-frame Verlet keeps the sphere's invariants and gets the precession right (its symplecticity is
checked with every other declared-symplectic method in ``tests/test_structure.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from foucault_bench.integrators import Problem, get_integrator
from foucault_bench.models import MODELS, PendulumParameters

PARIS = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)


def _fitted_precession_rate(turning: np.ndarray) -> float:
    """Least-squares slope of the unwrapped swing azimuth (rad/s); PHYSICS.md "Measuring the precession rate"."""
    azimuth = np.unwrap(2 * np.arctan2(turning[:, 2], turning[:, 1])) / 2
    return float(np.polyfit(turning[:, 0], azimuth, 1)[0])


def test_verlet_precesses_at_the_textbook_rate_where_rk4_of_equal_cost_does_not() -> None:
    """On the isotropic linear model the rotation and the oscillator commute, so the Verlet orbit's
    orientation turns at exactly −a; only the O((kh)²) interpolation of turning points between steps remains,
    and it oscillates instead of accumulating. RK4 at the same cost (2 evaluations per step against 4, so twice
    the step) is too slow by ≈ (kh)⁴/24 (PHYSICS.md "Integrators")."""
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
