"""Fixed-step schemes beyond the conformance checks: Euler's energy growth, divergence rows, tableau steps, streaming.

The observed order of every fixed-step integrator on every model and its stability limit are checked by the
conformance test of every built-in integrator (tests/test_selftest.py, the code behind ``foucault-bench selftest``,
on each model's example parameters); this module checks what the conformance checks do not. Theory (integrators/README.md "Fixed-step methods on this
problem"; Hairer & Wanner, Solving ODEs II, §IV.2): on ẍ = −k²x explicit Euler multiplies the energy by exactly
(1 + (kh)²) per step; RK4 is stable for kh ≤ 2√2; Störmer–Verlet for kh < 2. At the equator, or with Earth's rotation
off, the linear model is exactly that oscillator (in 2-D).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from foucault_bench.bench.gate.conformance import oscillator_run
from foucault_bench.integrators import REGISTRY, Problem, built_in_names, get_integrator
from foucault_bench.models import MODELS, PendulumParameters

FIXED_STEP = [name for name in built_in_names() if not REGISTRY[name].adaptive]
PARIS = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
EQUATOR = PendulumParameters(length_m=67.0, latitude_deg=0.0, amplitude_m=3.0)


def _energy_growth(integrator_name: str, kh: float, n_steps: int, params: PendulumParameters = EQUATOR):
    return oscillator_run(get_integrator(integrator_name), kh, n_steps, params)


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
    """RK4 on the linear model: turning points every half period on azimuth ψ₀ − a t (models/README.md
    "Closed forms")."""
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


def test_a_problem_hands_out_fresh_copies_of_its_vectors() -> None:
    """A problem computes its parameter vector and initial state once (a run's timed repeats solve one problem)
    and hands out copies: an integrator that wrote into them could not change what the next solve reads."""
    problem = Problem(MODELS["linear"], PARIS, np.linspace(0.0, 10.0, 11))
    problem.parameter_vector[:] = np.nan
    problem.initial_state[:] = np.nan
    np.testing.assert_array_equal(problem.parameter_vector, PARIS.parameter_vector())
    np.testing.assert_array_equal(problem.initial_state, PARIS.initial_state())


def _hand_written_rk4(acceleration):
    """RK4's step as it was written by hand before it became tableau data (the oracle of the test below)."""

    def step(x, y, vx, vy, h, p):
        half = 0.5 * h
        k1ax, k1ay = acceleration(x, y, vx, vy, p)
        x2 = x + half * vx
        y2 = y + half * vy
        vx2 = vx + half * k1ax
        vy2 = vy + half * k1ay
        k2ax, k2ay = acceleration(x2, y2, vx2, vy2, p)
        x3 = x + half * vx2
        y3 = y + half * vy2
        vx3 = vx + half * k2ax
        vy3 = vy + half * k2ay
        k3ax, k3ay = acceleration(x3, y3, vx3, vy3, p)
        x4 = x + h * vx3
        y4 = y + h * vy3
        vx4 = vx + h * k3ax
        vy4 = vy + h * k3ay
        k4ax, k4ay = acceleration(x4, y4, vx4, vy4, p)
        sixth = h / 6.0
        return (
            x + sixth * (vx + 2.0 * vx2 + 2.0 * vx3 + vx4),
            y + sixth * (vy + 2.0 * vy2 + 2.0 * vy3 + vy4),
            vx + sixth * (k1ax + 2.0 * k2ax + 2.0 * k3ax + k4ax),
            vy + sixth * (k1ay + 2.0 * k2ay + 2.0 * k3ay + k4ay),
        )

    return step


def _hand_written_explicit_euler(acceleration):
    """Explicit Euler's step as it was written by hand before it became tableau data."""

    def step(x, y, vx, vy, h, p):
        ax, ay = acceleration(x, y, vx, vy, p)
        return x + h * vx, y + h * vy, vx + h * ax, vy + h * ay

    return step


@pytest.mark.parametrize("name, hand_written", [("rk4", _hand_written_rk4),
                                                ("explicit_euler", _hand_written_explicit_euler)])
def test_tableau_steps_are_bitwise_the_hand_written_steps(name, hand_written) -> None:
    """The tableau-generated steps of RK4 and explicit Euler (integrators.explicit_rk) give bit for bit the states
    and streamed metrics of the hand-written steps they replaced, at two step sizes. One model suffices: both
    steps only combine the stages' calls of the model's acceleration, whatever it is; the spherical model's
    depends on all four state components, nonlinearly (sphere and Coriolis terms), so a wrong stage argument
    shows. Every other model's steps are checked by their declared order (tests/test_selftest.py, the
    conformance test applies the order check on every model)."""
    from foucault_bench.integrators.fixed_step import FixedStepIntegrator
    from foucault_bench.models.jit import jit

    class PlainSums(type(get_integrator(name))):  # the hand-written steps were added to the state with plain sums
        compensated_update = False

    tableau_driven = PlainSums()

    class HandWritten(FixedStepIntegrator):
        name, family, order, stages = "hand_written", "test", tableau_driven.order, tableau_driven.stages
        stability_limit_kh, reference = None, "test oracle"

        def make_step(self, model):
            return jit(hand_written(model.numba_acceleration))

    problem = Problem(MODELS["spherical"], PARIS, np.linspace(0.0, 3 * PARIS.small_swing_period_s, 31))
    for kh in (0.2, 0.05):
        step_s = kh / PARIS.pendulum_frequency_rad_s
        new, old = tableau_driven.solve(problem, step_s=step_s), HandWritten().solve(problem, step_s=step_s)
        assert new.status == old.status and new.steps == old.steps > 0
        assert np.array_equal(new.y, old.y, equal_nan=True)
        assert new.streamed.energy_max_rel_error == old.streamed.energy_max_rel_error
        assert new.streamed.energy_drift_per_s == old.streamed.energy_drift_per_s
        assert np.array_equal(new.streamed.turning_points, old.streamed.turning_points)


@pytest.mark.parametrize("name", ["rk4", "heun3", "nystrom4"])
def test_the_compensated_update_adds_the_steps_increment(name: str) -> None:
    """A tableau method's (and Nyström 4's) increment is its step without the added state: state + increment is the step bit for
    bit, so the compensated loop (integrators/fixed_step.py) differs from the plain one by the carried rounding
    only; over 20 000 steps at kh 0.01 that is round-off (≤ 1e-11 of the state), yet not nothing."""
    from foucault_bench.integrators.fixed_step import build_kernel

    integrator = get_integrator(name)
    model = MODELS["spherical"]
    step, increment = integrator.compiled_step(model), integrator.make_increment(model)
    assert increment is not None
    p, h = tuple(PARIS.parameter_vector()), 0.3 / PARIS.pendulum_frequency_rad_s
    for state in ([3.0, 0.0, 0.0, 0.0], [-1.2, 2.1, 0.3, -0.2]):
        d = increment(*state, h, p)
        assert tuple(s + di for s, di in zip(state, d, strict=True)) == step(*state, h, p)
    n, stride, h = 20_000, 1000, 0.01 / PARIS.pendulum_frequency_rad_s
    outs = [np.empty((n // stride + 1, 4)) for _ in range(2)]
    plain = build_kernel(step, model.numba_energy)
    for kernel, out in zip((integrator.kernel(model), plain), outs, strict=True):
        status, steps, *_ = kernel(np.array([3.0, 0.0, 0.0, 0.0]), PARIS.parameter_vector(), h, n, stride, out,
                                   False, np.empty((0, 3)), 1e6)
        assert status == 0 and steps == n
    difference = np.max(np.abs(outs[0] - outs[1]) / np.max(np.abs(outs[1]), axis=0))
    assert 0.0 < difference <= 1e-11
