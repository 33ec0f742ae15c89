"""Verdicts: the precession measurement, the Airy rate of the references, the verdict columns, observed order."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from foucault_bench.bench.problems.reference import reference_for
from foucault_bench.bench.problems.scenes import SCENES, Scene
from foucault_bench.bench.verdicts.columns import compute_verdicts
from foucault_bench.bench.verdicts.convergence import observed_order
from foucault_bench.bench.problems.turning_points import (
    HERMITE_NODES,
    LocalHermite,
    azimuth_error_bound,
    grid_accelerations,
    precession_rate,
    rate_error_bound,
    turning_points_from_grid,
    turning_time_error_bound,
)
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_FAILED, Solution, get_integrator
from foucault_bench.models.analytic import linear_exact
from numpy.polynomial.chebyshev import chebval
from scipy.optimize.elementwise import find_root


pytestmark = pytest.mark.usefixtures("fresh_reference_cache")


def shortened(scene: Scene, duration_s: float) -> Scene:
    return dataclasses.replace(scene, name=f"{scene.name}_short", duration_s=duration_s)


def measurement_bound(scene: Scene, turning_times_s: np.ndarray) -> float:
    """Worst-case error (rad/s) of a rate measured on the scene's grid (bench.problems.turning_points.azimuth_error_bound)."""
    return rate_error_bound(turning_times_s, azimuth_error_bound(scene.params, scene.output_interval_s,
                                                                 scene.duration_s))


# --- the measurement --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("rate_rad_s", [-5.49e-5, 7.3e-5, 0.0, 2.0e-3])
def test_precession_rate_recovers_a_known_rate_from_synthetic_turning_points(rate_rad_s: float) -> None:
    # alternate ends of the swing (ψ and ψ + π), azimuth noise σ, enough time for 2.0e-3 rad/s to wrap ψ past ±π
    rng = np.random.default_rng(12345)
    n, half_period_s, sigma_rad = 600, 8.2, 1e-6
    t = np.arange(n) * half_period_s
    psi = 1.0 + rate_rad_s * t + np.pi * (np.arange(n) % 2) + rng.normal(0.0, sigma_rad, n)
    radius = 3.0
    points = np.column_stack([t, radius * np.cos(psi), radius * np.sin(psi)])
    rate, stderr = precession_rate(points)
    # standard error of a least-squares slope with N points spread uniformly over T: σ√(12/N)/T (to 1/N)
    expected_stderr = sigma_rad * math.sqrt(12.0 / n) / (t[-1] - t[0])
    assert 0.8 * expected_stderr < stderr < 1.2 * expected_stderr
    assert abs(rate - rate_rad_s) < 5.0 * stderr


def test_precession_rate_needs_three_points() -> None:
    assert all(math.isnan(value) for value in precession_rate(np.array([[0.0, 1.0, 0.0], [1.0, -1.0, 0.0]])))


@pytest.mark.parametrize("scene_name", ["pantheon", "griffith"])
def test_turning_points_of_the_sampled_exact_linear_solution_give_the_textbook_rate(scene_name: str) -> None:
    scene = SCENES[scene_name]
    params = scene.params
    t = scene.output_grid()
    y = linear_exact(params, t)
    points = turning_points_from_grid(t, y, grid_accelerations(scene.model_object, params, y), include_release=True)
    a = params.vertical_rate_rad_s
    big_omega = math.hypot(params.pendulum_frequency_rad_s, a)
    # the exact turning points are t = nπ/Ω, n = 0, 1, … (models.analytic), each on azimuth ψ₀ − a t (mod π)
    assert points.shape[0] == math.floor(t[-1] * big_omega / math.pi) + 1
    time_bound = turning_time_error_bound(params, scene.output_interval_s, scene.duration_s)
    assert np.max(np.abs(points[:, 0] - np.pi / big_omega * np.arange(points.shape[0]))) <= time_bound
    azimuth_bound = azimuth_error_bound(params, scene.output_interval_s, scene.duration_s)
    measured = np.arctan2(points[:, 2], points[:, 1])
    textbook = np.radians(params.release_azimuth_deg) - a * points[:, 0]
    assert np.max(np.abs(np.angle(np.exp(2j * (measured - textbook))) / 2)) <= azimuth_bound
    rate, _ = precession_rate(points)
    assert abs(rate - params.textbook_precession_rate_rad_s) <= measurement_bound(scene, points[:, 0])


HEYOKA_EVENT_TIME_TOLERANCE_S = 1e-10
"""heyoka locates an event as a root of its step's Taylor polynomial: here within 8e-12 s of the grid measurement
(measured), except the last event, which falls in the step cut short by the end of the run (4.3e-10 s)."""


def test_grid_turning_points_agree_with_heyoka_event_turning_points() -> None:
    # an independent measurement: heyoka's event r·ṙ = 0 located on its own dense output (integrators.methods.heyoka_taylor)
    scene = shortened(SCENES["lab_3m"], 360.0)
    solution = get_integrator("heyoka_taylor").solve(scene.problem(), tol=1e-15, monitor=True)
    events = solution.streamed.turning_points
    points = turning_points_from_grid(solution.t, solution.y,
                                      grid_accelerations(scene.model_object, scene.params, solution.y), True)
    assert np.array_equal(points[0], [0.0, *scene.params.initial_state()[:2]])
    assert events.shape == points[1:].shape
    time_bound = turning_time_error_bound(scene.params, scene.output_interval_s, scene.duration_s)
    gap = np.abs(events[:, 0] - points[1:, 0])
    assert np.max(gap[:-1]) <= time_bound + HEYOKA_EVENT_TIME_TOLERANCE_S
    assert gap[-1] <= time_bound + 10 * HEYOKA_EVENT_TIME_TOLERANCE_S
    azimuth_gap = np.angle(np.exp(2j * (np.arctan2(events[:, 2], events[:, 1])
                                        - np.arctan2(points[1:, 2], points[1:, 1])))) / 2
    speed = scene.params.amplitude_m * scene.params.pendulum_frequency_rad_s  # bounds the tangential motion rate
    azimuth_tolerance = 10 * HEYOKA_EVENT_TIME_TOLERANCE_S * speed / scene.params.amplitude_m
    assert np.max(np.abs(azimuth_gap)) <= (azimuth_error_bound(scene.params, scene.output_interval_s, scene.duration_s)
                                           + azimuth_tolerance)


def scipy_roots(interpolant: LocalHermite) -> np.ndarray:
    """The roots as scipy finds them: ``find_root`` over all windows at once, default tolerances, on r·dr/dx of the
    interpolant evaluated with numpy's ``chebval`` (x ∈ [−1, 1] over the window, as ``LocalHermite.position``)."""

    def radial_velocity(offset: np.ndarray, window: np.ndarray) -> np.ndarray:  # the windows still in progress
        x = (offset - interpolant.centre) / interpolant.half_width
        position = [chebval(x, interpolant.coefficients[:, window, axis], tensor=False) for axis in (0, 1)]
        slope = [chebval(x, interpolant.derivative[:, window, axis], tensor=False) for axis in (0, 1)]
        return position[0] * slope[0] + position[1] * slope[1]

    windows = interpolant.coefficients.shape[1]
    return find_root(radial_velocity, (np.zeros(windows), np.ones(windows)), args=(np.arange(windows),)).x


def test_the_compiled_root_finder_finds_scipys_roots_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    # bench.problems.turning_point_roots is find_root's arithmetic compiled: on the windows of trajectories of two
    # models (a spherical run of dopri5 at a loose tolerance, the sampled exact linear solution, the latter with
    # relative noise of 1e-9 and 1e-4 on every value) every turning point equals the one scipy's root finder gives
    spherical = shortened(SCENES["lab_3m"], 360.0)
    run = get_integrator("dopri5").solve(spherical.problem(), tol=1e-6)
    linear = SCENES["pantheon"]
    exact_t = linear.output_grid()
    exact = linear_exact(linear.params, exact_t)
    wobble = np.sin(np.arange(exact.size)).reshape(exact.shape)
    trajectories = [(spherical, run.t, run.y)] + [(linear, exact_t, exact * (1.0 + noise * wobble))
                                                  for noise in (0.0, 1e-9, 1e-4)]
    compiled = [turning_points_from_grid(t, y, grid_accelerations(scene.model_object, scene.params, y), True)
                for scene, t, y in trajectories]
    monkeypatch.setattr(LocalHermite, "radial_velocity_roots", scipy_roots)
    for (scene, t, y), points in zip(trajectories, compiled, strict=True):
        expected = turning_points_from_grid(t, y, grid_accelerations(scene.model_object, scene.params, y), True)
        assert points.shape == expected.shape and points.shape[0] > 100
        assert np.array_equal(points, expected)


def test_the_compiled_root_finder_agrees_with_scipy_where_a_window_has_no_root() -> None:
    # random Chebyshev series: many windows do not change sign on [0, 1] (scipy: NaN), the others have roots
    # anywhere in the interval, with steep and flat ends
    rng = np.random.default_rng(2026)
    terms = 3 * HERMITE_NODES
    coefficients = rng.standard_normal((terms, 2000, 2)) * 0.5 ** np.arange(terms)[:, None, None]
    for shift in range(HERMITE_NODES - 1):
        interpolant = LocalHermite(coefficients, HERMITE_NODES, shift)
        roots = interpolant.radial_velocity_roots()
        expected = scipy_roots(interpolant)
        assert 0 < np.count_nonzero(np.isnan(expected)) < expected.size
        assert np.array_equal(roots, expected, equal_nan=True)


# --- the references' rates --------------------------------------------------------------------------------------


def test_linear_reference_rate_is_the_textbook_rate() -> None:
    scene = SCENES["pantheon"]
    reference = reference_for(scene)
    bound = measurement_bound(scene, reference.turning_points[:, 0])
    assert abs(reference.precession_rate_rad_s - scene.params.textbook_precession_rate_rad_s) <= bound


@pytest.mark.parametrize("scene_name, duration_s", [("airy_3m", 540.0), ("south_pole", 1200.0)])
def test_spherical_reference_rate_follows_airy(scene_name: str, duration_s: float) -> None:
    """Released from rest, the spherical pendulum's plane turns at −Ω_E sin φ (1 − (3/8)θ₀²) (models/README.md "Airy
    precession"). Neglected terms, relative to Ω_E sin φ: the next order of the amplitude expansion, c₄θ₀⁴, and the
    release-side term c₃θ₀³ cot φ cos ψ (from the horizontal part of ω, which pushes a North-South swing sideways;
    ψ is the swing's azimuth from South, so it vanishes for an East-West swing and at the poles). Their
    coefficients, measured with heyoka on the 3 m pendulum (θ₀ = 0.05-0.3, ψ₀ = 0°, 90°, 180°, 270°, at 40.44° N and
    90° S), are |c₄| ≤ 0.08 and |c₃| ≤ 0.27; the bound takes ½ for both, with max |cos ψ| over the swing's turn
    during the scene, plus the measurement bound. The scenes are shortened to keep the test fast."""
    scene = shortened(SCENES[scene_name], duration_s)
    params = scene.params
    reference = reference_for(scene)
    theta0 = params.amplitude_m / params.length_m
    textbook = params.textbook_precession_rate_rad_s
    airy = textbook * (1.0 - 0.375 * theta0**2)
    turned = abs(textbook) * scene.duration_s
    psi = np.radians(params.release_azimuth_deg) + np.linspace(-turned, turned, 1001)
    cot_phi = abs(math.cos(params.latitude_rad) / math.sin(params.latitude_rad))
    neglected = 0.5 * theta0**4 + 0.5 * theta0**3 * cot_phi * float(np.max(np.abs(np.cos(psi))))
    bound = neglected * abs(textbook) + measurement_bound(scene, reference.turning_points[:, 0])
    assert abs(reference.precession_rate_rad_s - airy) <= bound
    # the check has teeth: the Airy term itself is several times the bound
    assert 0.375 * theta0**2 * abs(textbook) > 5.0 * bound


# --- the verdict columns ----------------------------------------------------------------------------------------


def test_rk4_precession_error_is_the_predicted_lag() -> None:
    # RK4 on the oscillator: the plane precesses too slowly by (kh)⁴/24 (integrators/README.md "Fixed-step
    # methods on this problem"); the verdict must see that lag, with its sign, to within the next order (kh)²
    # and the measurement bound
    scene = SCENES["pantheon"]
    k = scene.params.pendulum_frequency_rad_s
    solution = get_integrator("rk4").solve(scene.problem(), step_s=0.08 / k)
    kh = solution.step_size_s * k
    verdicts = compute_verdicts(scene, solution, reference_for(scene))
    textbook = scene.params.textbook_precession_rate_rad_s
    lag = 1.0 - verdicts["precession_rate_rad_s"] / textbook
    predicted = kh**4 / 24.0
    assert abs(lag - predicted) <= predicted * kh**2 + 1e-7
    assert verdicts["precession_rate_error"] == pytest.approx(abs(lag), rel=1e-12)
    assert verdicts["turning_points"] > 400


def test_an_accurate_run_has_small_verdicts_and_the_reference_has_none() -> None:
    scene = SCENES["seed_2min"]
    reference = reference_for(scene)
    solution = get_integrator("heyoka_taylor").solve(scene.problem(), tol=1e-15)
    verdicts = compute_verdicts(scene, solution, reference)
    assert verdicts["energy_conserved"] == 1
    assert verdicts["energy_max_rel_error"] < 1e-13
    assert verdicts["reference_error"] < 1e-12
    assert verdicts["analytic_gap_exact"] < 1e-12
    # the seed's approximate solution misses the ellipse: its gap is ≈ a/k (models/README.md "Closed forms")
    a_over_k = scene.params.vertical_rate_rad_s / scene.params.pendulum_frequency_rad_s
    assert 0.9 * a_over_k < verdicts["analytic_gap_seed"] < 1.1 * a_over_k
    itself = Solution(t=reference.t, y=reference.y)
    verdicts = compute_verdicts(scene, itself, reference)
    assert verdicts["reference_error"] == 0.0
    assert verdicts["precession_rate_ref_error"] == 0.0


def test_energy_error_is_relative_to_the_swing_and_matches_the_streamed_steps() -> None:
    # one step per output interval: the streamed per-step max and the grid max see the same states
    scene = shortened(SCENES["lab_3m"], 90.0)
    solution = get_integrator("verlet").solve(scene.problem(), step_s=scene.output_interval_s)
    verdicts = compute_verdicts(scene, solution, None)
    assert verdicts["energy_max_rel_error_steps"] == pytest.approx(verdicts["energy_max_rel_error"], rel=1e-9)
    # Verlet's energy error oscillates with amplitude ≈ (kh)²/4 of the swing energy
    # (integrators/README.md "Fixed-step methods on this problem"),
    # not of the Jacobi integral's |E₀| ≈ gL, which is 2/θ₀² = 800 times larger here
    kh = scene.params.pendulum_frequency_rad_s * scene.output_interval_s
    assert 0.5 * kh**2 / 4 < verdicts["energy_max_rel_error"] < 2.0 * kh**2 / 4
    assert math.isnan(verdicts["reference_error"]) and math.isnan(verdicts["precession_rate_ref_error"])


def test_a_model_without_an_energy_integral_is_flagged() -> None:
    scene = dataclasses.replace(shortened(SCENES["pantheon"], 120.0), model="seed_planar")
    solution = get_integrator("rk4").solve(scene.problem(), step_s=0.01)
    verdicts = compute_verdicts(scene, solution, None)
    assert verdicts["energy_conserved"] == 0
    assert verdicts["energy_max_rel_error"] > 0.0


def test_failed_and_diverged_runs() -> None:
    scene = shortened(SCENES["lab_3m"], 180.0)
    problem = scene.problem()
    failed = compute_verdicts(scene, Solution.failure(problem.t_out, "boom", STATUS_FAILED), None)
    assert failed["energy_conserved"] == 1
    assert all(value is None or math.isnan(value) for key, value in failed.items()
               if key not in ("energy_conserved", "turning_points"))
    # explicit Euler grows the energy by (1 + (kh)²) per step: at kh = 0.8 it leaves the sphere within seconds
    diverged = get_integrator("explicit_euler").solve(problem, step_s=0.8 / scene.params.pendulum_frequency_rad_s)
    assert diverged.status == STATUS_DIVERGED
    verdicts = compute_verdicts(scene, diverged, reference_for(scene))
    assert math.isnan(verdicts["precession_rate_rad_s"]) and verdicts["turning_points"] == 0
    assert verdicts["energy_max_rel_error"] > 1.0
    assert verdicts["reference_error"] > 0.1


def test_verdicts_are_deterministic() -> None:
    scene = shortened(SCENES["lab_3m"], 90.0)
    reference = reference_for(scene)
    runs = [get_integrator("rk4").solve(scene.problem(), step_s=0.02) for _ in range(2)]
    first, second = (compute_verdicts(scene, run, reference) for run in runs)
    assert np.array_equal(np.array(list(first.values()), dtype=float), np.array(list(second.values()), dtype=float),
                          equal_nan=True)
    # the spherical model has no closed form: no analytic gap
    assert math.isnan(first["analytic_gap_exact"]) and math.isnan(first["analytic_gap_seed"])


def test_a_solution_on_another_grid_is_refused() -> None:
    scene = SCENES["seed_2min"]
    reference = reference_for(scene)
    other = Solution(t=reference.t[:-1], y=reference.y[:-1])
    with pytest.raises(ValueError, match="grid"):
        compute_verdicts(scene, other, reference)


# --- observed order ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("order", [1, 2, 4])
def test_observed_order_ignores_saturation_and_round_off(order: int) -> None:
    h = 2.0 ** -np.arange(0, 24, 1.0)
    truncation = 0.3 * h**order * (1.0 + 2.0 * h)  # a pre-asymptotic term at large h
    round_off = 1e-14 * h**-0.5  # round-off grows as the steps multiply
    errors = np.minimum(truncation + round_off, 2.0)  # saturates at O(1)
    assert observed_order(h, errors) == pytest.approx(order, abs=0.05)


def test_observed_order_of_real_sweeps() -> None:
    scene = SCENES["seed_2min"]
    problem = scene.problem()
    k = scene.params.pendulum_frequency_rad_s
    exact = linear_exact(scene.params, problem.t_out)
    for name, order in (("rk4", 4), ("verlet", 2), ("symplectic_euler", 1)):
        steps, errors = [], []
        for kh in 0.2 * 2.0 ** -np.arange(0, 11):
            solution = get_integrator(name).solve(problem, step_s=kh / k, monitor=False)
            gap = np.hypot(*(solution.y[:, :2] - exact[:, :2]).T).max() / scene.params.amplitude_m
            steps.append(solution.step_size_s)
            errors.append(gap)
        assert observed_order(steps, errors) == pytest.approx(order, abs=0.15), name


def test_observed_order_without_enough_points_is_nan() -> None:
    assert math.isnan(observed_order([0.1, 0.05], [np.nan, 1e-3]))
