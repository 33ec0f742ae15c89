"""The order-8 composition of the rotating-frame Verlet step (``integrators.methods.composition8``): its weights
as data, and the compiled step
as the same map as its Verlet sub-steps in a row (compiled in sequences of at most ``MAX_COMPILED_SUB_STEPS``).
composition8's observed order is measured by the registry-wide conformance test (tests/test_selftest.py)."""

from __future__ import annotations

import numpy as np
import pytest

from foucault_bench.integrators import get_integrator
from foucault_bench.integrators.composition import MAX_COMPILED_SUB_STEPS, Composition
from foucault_bench.integrators.methods.composition8 import KAHAN_LI_S17ODR8A
from foucault_bench.models import MODELS, PendulumParameters

PARIS = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)


@pytest.mark.parametrize("composition, stages", [(KAHAN_LI_S17ODR8A, 17)])
def test_the_weights_are_symmetric_sum_to_one_and_have_the_published_length(composition, stages) -> None:
    gamma = np.array(composition.weights)
    assert gamma.size == stages and np.array_equal(gamma, gamma[::-1])
    assert abs(gamma.sum() - 1.0) < 1e-15 * stages
    for power in range(3, composition.order, 2):
        assert abs(np.sum(gamma**power)) < 1e-15 * stages


def test_the_order_8_weights_are_refused_as_order_10() -> None:
    """s17odr8a is of order 8 only: Σγ⁹ = −7.5e-4, which the order-10 check must see."""
    assert abs(np.sum(np.array(KAHAN_LI_S17ODR8A.weights) ** 9)) > 1e-4
    with pytest.raises(ValueError, match="Σγ\\^9"):
        Composition(weights=KAHAN_LI_S17ODR8A.weights, order=10)


def test_a_perturbed_pair_of_weights_is_refused() -> None:
    """Moving a symmetric pair by δ and the middle weight by −2δ keeps Σγ = 1 and symmetry but breaks Σγ³ = 0."""
    gamma = list(KAHAN_LI_S17ODR8A.weights)
    delta = 1e-9
    gamma[3] += delta
    gamma[-4] += delta
    gamma[8] -= 2 * delta
    with pytest.raises(ValueError, match="Σγ\\^3"):
        Composition(weights=tuple(gamma), order=8)


@pytest.mark.parametrize("model", ["linear", "spherical"])
def test_a_chunked_composition_step_is_its_verlet_sub_steps_in_a_row(model: str) -> None:
    """composition8 (17 sub-steps) is compiled as sequences of at most 9; the step must be the same map as the
    17 Verlet steps γ₁h, …, γ₁₇h taken one after the other, to round-off."""
    composition = get_integrator("composition8")
    assert len(composition.composition.weights) > MAX_COMPILED_SUB_STEPS
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
    assert np.all(np.abs(np.subtract(composed, in_a_row)) <= 1e-13 * scale)


def test_nystrom4_declares_the_stability_limit_of_its_coefficients() -> None:
    """The spectral radius of Nyström 4's one-step matrix on ẍ = −x (step kh), from the coefficients, first
    exceeds 1 just above the declared limit and stays ≤ 1 below it."""
    from foucault_bench.integrators.methods.nystrom4 import Nystrom4

    def spectral_radius(kh: float) -> float:
        columns = []
        for y, v in ((1.0, 0.0), (0.0, 1.0)):
            k1 = -y
            k2 = -(y + kh / 2 * v + kh * kh / 8 * k1)
            k3 = k2  # same stage position, f independent of the velocity here
            k4 = -(y + kh * v + kh * kh / 2 * k3)
            columns.append((y + kh * v + kh * kh / 6 * (k1 + k2 + k3), v + kh / 6 * (k1 + 2 * k2 + 2 * k3 + k4)))
        return float(max(abs(np.linalg.eigvals(np.array(columns).T))))

    limit = Nystrom4.stability_limit_kh
    below = np.linspace(0.01, limit - 1e-4, 2000)
    assert all(spectral_radius(kh) <= 1.0 + 1e-12 for kh in below)
    assert spectral_radius(limit + 1e-4) > 1.0 + 1e-12
