"""The models' extension points: one parameter table, one heyoka parameter helper, a declared hierarchy, and a
model written in a test (a damped linear pendulum, as in models/README.md "Adding a model") running through
the same machinery as the built-in ones."""

from __future__ import annotations

import heyoka
import numpy as np
import pytest

from foucault_bench.bench.gate.conformance import ORDER_TOLERANCE
from foucault_bench.bench.gate.order_sweep import measure_order
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


def pushed_force(m, x, y, z, vx, vy, vz, p):
    """Linear model plus a constant push along x read from the last parameter slot: a term whose derivatives
    with respect to the state vanish, so the Jacobian reads fewer parameters than the right-hand side."""
    k2 = p[P_K2]
    a = p[P_OMEGA_Z]
    return -k2 * x + 2.0 * a * vy + 1e-3 * p[PARAMETER_COUNT - 1], -k2 * y - 2.0 * a * vx, 0.0 * z


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
    # the order measurement runs on it, and RK4 keeps its declared order (every integrator's order on the
    # built-in non-Hamiltonian models, Verlet through its remainder path, is the conformance test's:
    # tests/test_selftest.py)
    measured = measure_order(get_integrator("rk4"), DAMPED)
    assert abs(measured.order - get_integrator("rk4").order) <= ORDER_TOLERANCE, measured
    # and the physics is the one written: at whole periods the swing energy is E₀ exp(−γt), γ = k/Q, up to
    # terms of relative order (γ/k)² = 1/Q² = 4e-4 (the oscillating part of dE/dt = −γ|v|² averages out over a
    # period; Landau & Lifshitz, Mechanics, §25); measured 6e-5
    period = LAB.small_swing_period_s
    grid = np.linspace(0.0, 10 * period, 11)
    solution = get_integrator("rk4").solve(Problem(DAMPED, LAB, grid), step_s=period / 400)
    energy = np.array([DAMPED.numba_energy(*row, p) for row in solution.y])
    gamma = LAB.pendulum_frequency_rad_s / QUALITY_FACTOR
    np.testing.assert_allclose(energy / energy[0], np.exp(-gamma * grid), rtol=1.0 / QUALITY_FACTOR**2)


# --- models extend by declaration ----------------------------------------------------------------------------

STIFFENING = 0.1
"""Relative extra stiffness of the test refinement below when its switch is off."""


def stiffened_force(m, x, y, z, vx, vy, vz, p):
    """The linear force plus an extra spring (1 − c)·κk² acting only when the switch c = p[P_CENTRIFUGAL] is off
    (a test refinement: at the switch's default, on, it is the linear model exactly)."""
    k2 = p[P_K2] * (1.0 + STIFFENING * (1.0 - p[parameters.P_CENTRIFUGAL]))
    a = p[P_OMEGA_Z]
    return -k2 * x + 2.0 * a * vy, -k2 * y - 2.0 * a * vx, 0.0 * z


STIFFENED = Model(name="stiffened_linear_test", title="stiffened linear (test)", geometry="plane",
                  free_force=stiffened_force, energy=linear_energy, energy_name="E", conserves_energy=False,
                  hamiltonian=True, refines=("linear",), example_parameters={"centrifugal": False},
                  adds_parameters=("centrifugal",))


@pytest.fixture
def registered_stiffened(monkeypatch):
    """``STIFFENED`` in the model registry for one test, as a discovered module's ``MODEL`` would be."""
    import foucault_bench.models as models

    monkeypatch.setitem(models.MODELS, STIFFENED.name, STIFFENED)
    yield STIFFENED


def test_a_new_parameter_field_gets_its_index_constant_and_slot_from_the_table() -> None:
    import dataclasses

    @dataclasses.dataclass(frozen=True)
    class AnisotropicParameters(PendulumParameters):
        anisotropy: float = dataclasses.field(default=0.0, metadata=parameters.rule(unit="1"))

    slots = parameters.parameter_slots(AnisotropicParameters)
    constants = parameters.index_constants(slots)
    assert constants["P_ANISOTROPY"] == len(PARAMETER_SLOTS) == PARAMETER_COUNT
    assert {name: constants[name] for name in parameters.INDEX_CONSTANTS} == parameters.INDEX_CONSTANTS
    vector = AnisotropicParameters(length_m=3.0, latitude_deg=48.846, amplitude_m=0.3, anisotropy=0.25).parameter_vector()
    assert vector.shape == (PARAMETER_COUNT + 1,) and vector[constants["P_ANISOTROPY"]] == 0.25
    # the built-in constants are the module's, derived from the same table
    for name, index in parameters.INDEX_CONSTANTS.items():
        assert getattr(parameters, name) == index
    assert parameters.P_CENTRIFUGAL == PARAMETER_SLOTS.index(
        next(slot for slot in PARAMETER_SLOTS if slot.name == "centrifugal"))


def test_a_model_refuses_example_parameters_that_exercise_nothing() -> None:
    common = dict(title="t", geometry="plane", free_force=stiffened_force, energy=linear_energy, energy_name="E",
                  conserves_energy=False, hamiltonian=True)
    with pytest.raises(ValueError, match="no field"):
        Model(name="bad", example_parameters={"stiffness": 1.0}, **common)
    with pytest.raises(ValueError, match="is its default"):
        Model(name="bad", example_parameters={"centrifugal": True}, **common)
    with pytest.raises(ValueError, match="no example value"):
        Model(name="bad", adds_parameters=("centrifugal",), **common)


def test_selftest_checks_a_refinement_at_its_example_parameters_not_where_it_equals_its_parent() -> None:
    from foucault_bench.bench.gate.conformance import check_order
    from foucault_bench.bench.gate.order_sweep import ORDER_PARAMS, order_parameters

    assert STIFFENED.equals_parents_at(ORDER_PARAMS)
    params = order_parameters(STIFFENED)
    assert params.centrifugal is False and not STIFFENED.equals_parents_at(params)
    assert dataclasses_replace_equals(params, ORDER_PARAMS, centrifugal=False)
    # at the example parameters the model differs from its parent (the extra spring acts) ...
    state = np.array([0.1, 0.2, -0.05, 0.3])
    assert not np.allclose(STIFFENED.numba_rhs(0.0, state, params.parameter_vector()),
                           MODELS["linear"].numba_rhs(0.0, state, params.parameter_vector()))
    # ... and the order check runs there and says so
    check = check_order(get_integrator("rk4"), STIFFENED)
    assert check.holds is True and "centrifugal = False" in check.detail and "held" in check.detail, check


def dataclasses_replace_equals(params: PendulumParameters, base: PendulumParameters, **changes) -> bool:
    import dataclasses

    return params == dataclasses.replace(base, **changes)


@pytest.mark.usefixtures("fresh_reference_cache")
def test_a_refinement_at_its_parents_values_adds_no_adequacy_row_and_no_reference_run(registered_stiffened,
                                                                                       monkeypatch) -> None:
    import dataclasses

    from foucault_bench.bench.verdicts import adequacy
    from foucault_bench.bench.problems.scenes import SCENES

    models_run: list[str] = []
    real_reference_for = adequacy.reference_for

    def recording_reference_for(scene):
        models_run.append(scene.model)
        return real_reference_for(scene)

    monkeypatch.setattr(adequacy, "reference_for", recording_reference_for)
    scene = dataclasses.replace(SCENES["pantheon"], name="pantheon_short", duration_s=120.0)
    assert scene.params.centrifugal is True  # the switch at its default: the refinement is the linear model
    rows = adequacy.model_adequacy(scene)
    assert STIFFENED.name not in {row["model"] for row in rows} and STIFFENED.name not in models_run
    assert {row["model"] for row in rows} == {"seed_planar", "spherical"}
    # with the switch off the refinement acts, and the study compares it with its parent
    switched = dataclasses.replace(scene, name="pantheon_switched",
                                   params=dataclasses.replace(scene.params, centrifugal=False))
    rows = {row["model"]: row for row in adequacy.model_adequacy(switched)}
    assert rows[STIFFENED.name]["simpler_model"] == "linear"
    # a 10 % stiffer spring shifts the swing frequency by ≈ 5 %: the trajectories part by O(A) within 120 s
    assert rows[STIFFENED.name]["trajectory_gap"] > 0.1


def test_the_jacobian_of_a_model_with_a_constant_push_is_the_linear_models() -> None:
    """A parameter that only adds a state-independent term is absent from the derivatives; the compiled
    Jacobian must still take the parameter vector (heyoka refuses a longer one) and give the linear model's."""
    pushed = Model(name="pushed_linear_test", title="pushed linear (test)", geometry="plane",
                   free_force=pushed_force, energy=linear_energy, energy_name="E", conserves_energy=False,
                   hamiltonian=False, refines=("linear",))
    vector = LAB.parameter_vector()
    state = np.array([0.1, -0.2, 0.03, 0.04])
    ours, linear = np.empty((4, 4)), np.empty((4, 4))
    pushed.jacobian_into(0.0, state, ours, vector)
    MODELS["linear"].jacobian_into(0.0, state, linear, vector)
    np.testing.assert_array_equal(ours, linear)


def test_the_order_check_releases_a_model_on_the_ellipse_it_declares() -> None:
    """``Model.order_sweep_ellipse`` (models/README.md "Drag and drive"): the order sweep of a model declaring
    b/a releases it with a sideways speed b/a · kA at right angles to the release direction, and a model
    declaring none from rest; a ratio outside [0, 1] is refused. On ``damped_linear`` this is what lets an order-8
    method show its order: released from rest, the smoothed |ṙ|ṙ's singularities near every turning point hold
    the fit far below 8 (measured 4.9 with halvings, 2.8 with the high-order sweep, whose finer steps stall at
    1e-9), on the declared ellipse it is 8 within the selftest's tolerance."""
    import dataclasses
    import math

    from foucault_bench.bench.gate.order_sweep import ORDER_PARAMS, order_parameters

    damped = MODELS["damped_linear"]
    params = order_parameters(damped)
    k, amplitude = params.pendulum_frequency_rad_s, params.amplitude_m
    x0, y0, vx0, vy0 = params.initial_state()
    assert damped.order_sweep_ellipse == pytest.approx(0.8)
    assert math.hypot(vx0, vy0) == pytest.approx(0.8 * k * amplitude, rel=1e-12)
    assert abs(x0 * vx0 + y0 * vy0) <= 1e-12 * amplitude * k * amplitude  # at right angles to the release
    assert order_parameters(MODELS["linear"]).release_velocity_m_s == ORDER_PARAMS.release_velocity_m_s == (0.0, 0.0)
    with pytest.raises(ValueError, match="order_sweep_ellipse must lie in"):
        dataclasses.replace(damped, name="bad_ellipse", order_sweep_ellipse=1.5)
    composition8 = get_integrator("composition8")
    on_the_ellipse = measure_order(composition8, damped).order
    from_rest = measure_order(composition8, damped, dataclasses.replace(params, release_velocity_m_s=(0.0, 0.0))).order
    assert abs(on_the_ellipse - 8) <= ORDER_TOLERANCE and not from_rest > 7.0, (on_the_ellipse, from_rest)
