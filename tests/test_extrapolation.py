"""Gragg-Bulirsch-Stoer extrapolation (``integrators.extrapolation``, ``integrators.extrapolation_driver``, the
integrators ``gbs4`` and ``gbs``): the compiled fixed-order step against an independent Aitken-Neville table in
Python, the stability limit against the compiled step's one-step matrix, the counted evaluations, and the
adaptive driver's accuracy, output grid and failure rows. The observed order of ``gbs4`` on every model is
measured by the conformance test of every built-in integrator (tests/test_selftest.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from foucault_bench.integrators import STATUS_FAILED, STATUS_OK, Problem, get_integrator
from foucault_bench.integrators.extrapolation import (
    HARMONIC,
    ROMBERG,
    extrapolation_weights,
    oscillator_stability_limit,
    step_numbers,
)
from foucault_bench.models import MODELS, PendulumParameters
from foucault_bench.models.analytic import linear_exact

PARAMS = PendulumParameters(length_m=3.0, latitude_deg=40.0, amplitude_m=0.3, earth_rate_rad_s=0.2 * math.sqrt(9.81 / 3.0))
OSCILLATOR = PendulumParameters(length_m=1.0, latitude_deg=45.0, amplitude_m=0.1, earth_rate_rad_s=0.0)


def python_table_step(model, params, state, big_h, numbers):
    """One step of T_kk by the textbook recipe (HNW I, §II.9): the smoothed midpoint rule in numpy for each n_j,
    then the Aitken-Neville table row by row (T_{j,l+1} = T_{j,l} + (T_{j,l} − T_{j−1,l}) / ((n_j/n_{j−l})² − 1))."""
    p = tuple(params.parameter_vector())

    def f(z):
        ax, ay = model.acceleration(math, z[0], z[1], z[2], z[3], p)
        return np.array([z[2], z[3], ax, ay])

    rows: list[list[np.ndarray]] = []
    for j, n in enumerate(numbers):
        h = big_h / n
        previous, current = state.copy(), state + h * f(state)
        for _ in range(n - 1):
            previous, current = current, previous + 2 * h * f(current)
        row = [0.5 * (previous + current + h * f(current))]
        for level in range(j):
            ratio = (n / numbers[j - level - 1]) ** 2
            row.append(row[level] + (row[level] - rows[j - 1][level]) / (ratio - 1))
        rows.append(row)
    return rows[-1][-1]


@pytest.mark.parametrize("model_name", ["linear", "damped_linear", "spherical"])
def test_the_compiled_fixed_order_step_is_the_aitken_neville_table(model_name) -> None:
    model = MODELS[model_name]
    params = model.with_example_parameters(PARAMS)
    integrator = get_integrator("gbs4")
    state = np.array([0.3, 0.01, -0.02, 0.05])
    big_h = 0.4 / params.pendulum_frequency_rad_s
    compiled = np.array(integrator.compiled_step(model)(*state, big_h, tuple(params.parameter_vector())))
    expected = python_table_step(model, params, state, big_h, integrator.step_numbers)
    assert np.allclose(compiled, expected, rtol=0.0, atol=1e-14 * np.abs(expected).max())
    assert not np.allclose(compiled, python_table_step(model, params, state, big_h, (2,)), rtol=0.0, atol=1e-12)


def test_weights_are_the_table_and_sum_to_one() -> None:
    for kind in (HARMONIC, ROMBERG):
        for lines in range(1, 7):
            numbers = step_numbers(kind, lines)
            weights = extrapolation_weights(numbers)
            assert math.isclose(sum(weights), 1.0, abs_tol=1e-13)
            # extrapolation to h = 0 removes the terms h^(2d), 0 < d < lines, of the expansion
            for degree in range(1, lines):
                assert abs(sum(w * (1.0 / n) ** (2 * degree) for w, n in zip(weights, numbers, strict=True))) < 1e-14


def one_step_spectral_radius(integrator, kh: float) -> float:
    """|λ|max of the compiled step's one-step matrix on the undamped oscillator (columns: the unit states)."""
    step = integrator.compiled_step(MODELS["linear"])
    p = tuple(OSCILLATOR.parameter_vector())
    h = kh / OSCILLATOR.pendulum_frequency_rad_s
    columns = [step(*unit, h, p) for unit in np.eye(4)]
    return float(max(abs(np.linalg.eigvals(np.array(columns).T))))


def test_gbs4_declares_the_stability_limit_of_its_step() -> None:
    integrator = get_integrator("gbs4")
    limit = integrator.stability_limit_kh
    computed = oscillator_stability_limit(integrator.step_numbers)
    assert computed is not None and limit <= computed < limit + 1e-4
    assert all(one_step_spectral_radius(integrator, kh) <= 1.0 + 1e-13 for kh in np.linspace(0.05, limit, 60))
    assert one_step_spectral_radius(integrator, computed + 1e-3) > 1.0 + 1e-9


def test_odd_line_counts_grow_at_every_step() -> None:
    """T_kk with k odd has |R(iy)| > 1 for small y (no stability interval): the limit is None."""
    for lines in (1, 3, 5):
        assert oscillator_stability_limit(step_numbers(HARMONIC, lines)) is None
    assert oscillator_stability_limit(step_numbers(HARMONIC, 4)) == pytest.approx(3.852868, abs=1e-6)


def test_gbs4_counts_its_evaluations() -> None:
    integrator = get_integrator("gbs4")
    assert integrator.stages == 1 + 2 + 4 == integrator.evaluations_per_step(MODELS["spherical"])
    assert integrator.order == 4


def linear_problem(periods: float, n_out: int) -> tuple[Problem, np.ndarray]:
    params = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
    t_out = np.linspace(0.0, periods * params.small_swing_period_s, n_out)
    return Problem(MODELS["linear"], params, t_out), linear_exact(params, t_out)


def test_gbs_error_follows_the_tolerance_on_the_output_grid() -> None:
    """On the linear model against the closed form: the error over the grid falls with the tolerance and stays
    within 100 × tol of the amplitude over 5 periods; counters are filled; two runs agree bit for bit."""
    problem, exact = linear_problem(5.0, 41)
    integrator = get_integrator("gbs")
    errors = []
    for tol in (1e-6, 1e-9, 1e-12):
        solution = integrator.solve(problem, tol=tol)
        assert solution.status == STATUS_OK, solution.message
        assert solution.steps >= problem.t_out.size - 1 and solution.nfev > 7 * solution.steps
        error = float(np.abs(solution.y[:, :2] - exact[:, :2]).max() / 3.0)
        assert error < 100 * tol
        errors.append(error)
        assert np.array_equal(solution.y, integrator.solve(problem, tol=tol).y)
    assert errors[0] > errors[1] > errors[2]


def test_gbs_step_limit_is_a_failed_row() -> None:
    from foucault_bench.integrators.methods.gbs import Gbs

    problem, _ = linear_problem(5.0, 41)
    solution = Gbs(max_steps=5).solve(problem, tol=1e-9)
    assert solution.status == STATUS_FAILED and "step limit of 5" in solution.message
    assert np.all(np.isnan(solution.y[-1])) and np.all(np.isfinite(solution.y[0]))
