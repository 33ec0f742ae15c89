"""The rotating-frame Verlet is symplectic, keeps the sphere's invariants, and gets the precession right.

Symplecticity is checked on its one-step map Φ in canonical coordinates (r, p), p = ṙ + ω_c×r: the Jacobian
M = ∂Φ/∂(r, p) must satisfy Mᵀ J M = J (Hairer, Lubich & Wanner, Geometric Numerical Integration, Def. VI.2.2).
The same check on RK4 (not symplectic) must fail, so the test can tell the difference.
"""

from __future__ import annotations

import numpy as np
import pytest

from foucault_bench.integrators import Problem, get_integrator
from foucault_bench.models import MODELS, PendulumParameters
from foucault_bench.models.parameters import P_OMEGA_Z

PARIS = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
J = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.eye(2), np.zeros((2, 2))]])


def _canonical_step(integrator_name: str, params: PendulumParameters, h: float):
    """One step as a map of planar canonical coordinates (x, y, p_x, p_y), p = v + a ẑ×r."""
    model = MODELS["linear"]
    step = get_integrator(integrator_name).make_step(model)
    p = params.parameter_vector()
    a = p[P_OMEGA_Z]

    def canonical_map(z: np.ndarray) -> np.ndarray:
        x, y, px, py = z
        xn, yn, vxn, vyn = step(x, y, px + a * y, py - a * x, h, p)
        return np.array([xn, yn, vxn - a * yn, vyn + a * xn])

    return canonical_map


def _symplecticity_defect(integrator_name: str, h: float) -> float:
    canonical_map = _canonical_step(integrator_name, PARIS, h)
    z0 = np.array([0.7, 2.1, -0.2, 0.15])
    scale = np.array([1.0, 1.0, 0.4, 0.4])
    jacobian = np.empty((4, 4))
    for j in range(4):  # central differences, truncation ~ δ² × third derivative: the maps are (nearly) linear
        dz = np.zeros(4)
        dz[j] = 1e-5 * scale[j]
        jacobian[:, j] = (canonical_map(z0 + dz) - canonical_map(z0 - dz)) / (2 * dz[j])
    return float(np.max(np.abs(jacobian.T @ J @ jacobian - J)))


def test_verlet_one_step_map_is_symplectic_and_rk4_is_not() -> None:
    k = PARIS.pendulum_frequency_rad_s
    h = 0.5 / k
    assert _symplecticity_defect("verlet", h) < 1e-9
    # RK4's defect is of the size of its error constant: 1 − |R(ikh)|² ≈ (kh)⁶/72 ≈ 2e-4 at kh = 0.5
    assert _symplecticity_defect("rk4", h) > 1e-5


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
