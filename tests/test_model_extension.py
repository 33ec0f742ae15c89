"""The models' extension points: one parameter table, one heyoka parameter helper, a declared hierarchy, and a
model written in a test (a damped linear pendulum, as in models/README.md "Adding a model") running through
the same machinery as the built-in ones."""

from __future__ import annotations

import heyoka
import numpy as np
import pytest

from foucault_bench.bench.gate.conformance import ORDER_TOLERANCE, measure_order
from foucault_bench.integrators import Problem, get_integrator
from foucault_bench.models import MODELS, Model, PendulumParameters, richer_models, simpler_models
from foucault_bench.models import parameters
from foucault_bench.models.parameters import P_K2, P_OMEGA_Z, PARAMETER_COUNT, PARAMETER_SLOTS

QUALITY_FACTOR = 50.0


def damped_force(m, x, y, z, vx, vy, vz, p):
    """Linear model plus viscous damping γ = k/Q (Landau & Lifshitz, Mechanics, §25)."""
    k2 = p[P_K2]
    a = p[P_OMEGA_Z]
    gamma = m.sqrt(k2) / QUALITY_FACTOR
    return -k2 * x + 2.0 * a * vy - gamma * vx, -k2 * y - 2.0 * a * vx - gamma * vy, 0.0 * z


def linear_energy(m, x, y, vx, vy, p):
    return 0.5 * (vx * vx + vy * vy) + 0.5 * p[P_K2] * (x * x + y * y)


DAMPED = Model(name="damped_linear_test", title="damped linear (test)", geometry="plane", free_force=damped_force,
               energy=linear_energy, energy_name="E", conserves_energy=False, hamiltonian=False, refines=("linear",))
LAB = PendulumParameters(length_m=3.0, latitude_deg=48.846, amplitude_m=0.3)


def test_the_parameter_vector_is_laid_out_by_its_table() -> None:
    vector = LAB.parameter_vector()
    assert vector.shape == (PARAMETER_COUNT,) == (len(PARAMETER_SLOTS),)
    for index, slot in enumerate(PARAMETER_SLOTS):
        assert vector[index] == slot.value(LAB)
        assert parameters.PARAMETER_INDEX[slot.name] == index
    assert vector[parameters.P_K2] == LAB.gravity_m_s2 / LAB.length_m
    assert vector[parameters.P_OMEGA_Z] == LAB.vertical_rate_rad_s


def test_heyoka_gets_exactly_the_parameters_its_expressions_read() -> None:
    stack = np.array([LAB.parameter_vector()] * 3)
    for model in (*MODELS.values(), DAMPED):
        count = model.heyoka_parameter_count
        assert model.heyoka_parameters(LAB.parameter_vector()).shape == (count,)
        assert model.heyoka_parameters(stack).shape == (3, count)
    with pytest.raises(ValueError, match="full parameter vectors"):
        MODELS["linear"].heyoka_parameters(LAB.parameter_vector()[:-1])


def test_the_declared_hierarchy_orders_the_models() -> None:
    assert list(MODELS)[0] == "linear"
    for name, model in MODELS.items():
        assert set(model.refines) <= set(simpler_models(name))
        for simpler in simpler_models(name):
            assert name in richer_models(simpler)
    assert simpler_models("spherical") == ("linear", "seed_planar")


def test_a_model_written_in_a_test_runs_through_the_machinery() -> None:
    # its compiled and symbolic forms agree
    state = np.array([0.1, 0.2, -0.05, 0.3])
    p = LAB.parameter_vector()
    system = DAMPED.heyoka_system()
    compiled = heyoka.cfunc([rhs for _, rhs in system], vars=[variable for variable, _ in system])
    np.testing.assert_allclose(compiled(state, pars=DAMPED.heyoka_parameters(p)), DAMPED.numba_rhs(0.0, state, p),
                               rtol=1e-14, atol=1e-16)
    # the integrators keep their declared order on it (Verlet through its non-Hamiltonian remainder path)
    for name in ("rk4", "verlet"):
        measured = measure_order(get_integrator(name), DAMPED)
        assert abs(measured.order - get_integrator(name).order) <= ORDER_TOLERANCE, (name, measured)
    # and the physics is the one written: at whole periods the swing energy is E₀ exp(−γt), γ = k/Q, up to
    # terms of relative order (γ/k)² = 1/Q² = 4e-4 (the oscillating part of dE/dt = −γ|v|² averages out over a
    # period; Landau & Lifshitz, Mechanics, §25); measured 6e-5
    period = LAB.small_swing_period_s
    grid = np.linspace(0.0, 10 * period, 11)
    solution = get_integrator("rk4").solve(Problem(DAMPED, LAB, grid), step_s=period / 400)
    energy = np.array([DAMPED.numba_energy(*row, p) for row in solution.y])
    gamma = LAB.pendulum_frequency_rad_s / QUALITY_FACTOR
    np.testing.assert_allclose(energy / energy[0], np.exp(-gamma * grid), rtol=1.0 / QUALITY_FACTOR**2)
