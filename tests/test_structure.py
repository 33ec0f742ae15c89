"""Geometric properties that integrators declare, checked on their own compiled step (one test each, over every
integrator that declares the property, with a negative control that must fail the same check).

On the linear model each fixed-step scheme is a linear map M of (x, y, ẋ, ẏ) (``bench.verdicts.stability``):

* ``symplectic``: M in canonical variables (r, p = v + a ẑ×r) satisfies Mᵀ J M = J (Hairer, Lubich & Wanner,
  Geometric Numerical Integration, 2nd ed., Def. VI.2.2);
* ``volume_preserving``: det M = 1;
* ``conserves_quadratic_invariants``: the linear model's energy ½|v|² + ½k²|r|² (quadratic; the Coriolis force
  does no work) is kept to round-off over a long run;
* ``stability_limit_kh``: the one-step map stops growing exactly there without rotation;
* ``rotation_growth_per_step``: the measured growth with rotation follows the declared law.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from foucault_bench.bench.verdicts.stability import (
    measured_stability_limit,
    spectral_growth,
    step_matrix,
    symplecticity_defect,
    volume_defect,
)
from foucault_bench.integrators import Problem, get_integrator
from foucault_bench.integrators.composition import Composition, triple_jump
from foucault_bench.integrators.registry import REGISTRY, built_in_names
from foucault_bench.models import MODELS, PendulumParameters

PARIS_10M = PendulumParameters(length_m=10.0, latitude_deg=48.846, amplitude_m=1.0)
NO_ROTATION = PendulumParameters(length_m=10.0, latitude_deg=48.846, amplitude_m=1.0, earth_rate_rad_s=0.0)
FIXED_STEP = [name for name in built_in_names() if not REGISTRY[name].adaptive]  # plug-ins: their selftest
ROUND_OFF = 1e-12
"""Defects of an exact property: entries of M are O(1) and carry ~1e-15 round-off (the implicit schemes ~1e-14
from their solve), so 1e-12 is a margin of 100–1000."""


def _declaring(attribute: str) -> list[str]:
    return [name for name in FIXED_STEP if getattr(REGISTRY[name], attribute)]


def _matrix(name: str, kh: float, params: PendulumParameters = PARIS_10M) -> np.ndarray:
    return step_matrix(REGISTRY[name], params, kh / params.pendulum_frequency_rad_s)


def _safe_kh(name: str) -> list[float]:
    """Two step sizes inside the declared stability limit (or 0.5 and 1 where none is declared)."""
    limit = REGISTRY[name].stability_limit_kh or 2.0
    return [0.25 * limit, 0.6 * limit]


@pytest.mark.parametrize("name", _declaring("symplectic"))
def test_declared_symplectic_step_maps_are_symplectic(name: str) -> None:
    for kh in _safe_kh(name):
        assert symplecticity_defect(_matrix(name, kh), PARIS_10M) < ROUND_OFF, kh


@pytest.mark.parametrize("name", sorted(set(_declaring("volume_preserving")) | set(_declaring("symplectic"))))
def test_declared_volume_preserving_step_maps_keep_volume(name: str) -> None:
    for kh in _safe_kh(name):
        assert volume_defect(_matrix(name, kh)) < ROUND_OFF, kh


def test_the_checks_reject_a_method_without_the_property() -> None:
    """RK4 is neither symplectic nor volume-preserving: |R(ikh)|² = 1 − (kh)⁶/72 + (kh)⁸/576 per mode, so
    det M − 1 ≈ −4·(kh)⁶/72 ≈ −2e-3 at kh = 0.6 and the symplectic defect is of the same size."""
    matrix = _matrix("rk4", 0.6)
    assert symplecticity_defect(matrix, PARIS_10M) > 1e-4
    assert volume_defect(matrix) > 1e-4


@pytest.mark.parametrize("name", _declaring("conserves_quadratic_invariants"))
def test_quadratic_invariant_kept_to_round_off_over_a_long_run(name: str) -> None:
    """20 000 steps at kh = 0.5: what is left is round-off, at most a few ε per step even if it accumulated
    linearly: bound 4ε per step, 1.8e-11; measured 1.3e-14 and 2.0e-14 (a random walk of round-off,
    ``tests/test_long_time_roundoff.py``). Any truncation error is far above it."""
    steps = 20_000
    h = 0.5 / PARIS_10M.pendulum_frequency_rad_s
    problem = Problem(MODELS["linear"], PARIS_10M, np.linspace(0.0, steps * h, 11))
    solution = get_integrator(name).solve(problem, step_s=h)
    assert solution.status == "ok"
    assert solution.streamed.energy_max_rel_error < 4 * np.finfo(np.float64).eps * steps
    # the control: Verlet (symplectic, not quadratic-invariant-preserving for this energy) oscillates at O((kh)²)
    verlet = get_integrator("verlet").solve(problem, step_s=h)
    assert verlet.streamed.energy_max_rel_error > 1e-3


@pytest.mark.parametrize("name", [n for n in FIXED_STEP if REGISTRY[n].stability_limit_kh is not None])
def test_measured_stability_limit_is_the_declared_one(name: str) -> None:
    declared = REGISTRY[name].stability_limit_kh
    grid = np.round(np.arange(0.1, max(4.0, 1.1 * declared) + 0.05, 0.1), 6)  # composition10's limit is 5.97
    measured = measured_stability_limit(REGISTRY[name], NO_ROTATION, grid, resolution_kh=1e-5)
    # 1e-3: the implicit schemes' sweeps stop reaching Newton's hand-over 1e-4 below the limit (integrators.gauss)
    assert measured == pytest.approx(declared, rel=1e-3)


def _splitting_limit(half_trace) -> float:
    """The first kh > 0 where |½ trace| of a splitting's one-step matrix on ẍ = −x (det 1) reaches 1: a scan in
    steps of 1e-3, then bisection to 1e-10."""
    unstable = next(kh for kh in np.arange(1, 10_001) * 1e-3 if abs(half_trace(kh)) >= 1.0)
    low, high = unstable - 1e-3, unstable
    while high - low > 1e-10:
        middle = 0.5 * (low + high)
        low, high = (low, middle) if abs(half_trace(middle)) >= 1.0 else (middle, high)
    return low


def _drift(s: float) -> np.ndarray:
    return np.array([[1.0, s], [0.0, 1.0]])


def _kick(s: float) -> np.ndarray:
    return np.array([[1.0, 0.0], [-s, 1.0]])


COEFFICIENT_LIMITS = {
    # Störmer-Verlet, D(h/2) K(h) D(h/2) (Boris without rotation: its Coriolis turn is the identity)
    "verlet": lambda: _splitting_limit(lambda kh: 0.5 * np.trace(_drift(kh / 2) @ _kick(kh) @ _drift(kh / 2))),
    "boris": lambda: _splitting_limit(lambda kh: 0.5 * np.trace(_drift(kh / 2) @ _kick(kh / 2) @ _kick(kh / 2)
                                                                @ _drift(kh / 2))),
    "symplectic_euler": lambda: _splitting_limit(lambda kh: 0.5 * np.trace(_drift(kh) @ _kick(kh))),
    # the implicit schemes: the fixed-point solve's limit 1/ρ(A) (integrators.gauss "Limit")
    "implicit_midpoint": lambda: 1.0 / max(abs(np.linalg.eigvals(np.array([[0.5]])))),
    "gauss_legendre4": lambda: 1.0 / max(abs(np.linalg.eigvals(np.array([[0.25, 0.25 - math.sqrt(3) / 6],
                                                                         [0.25 + math.sqrt(3) / 6, 0.25]])))),
}
"""The fixed-step schemes whose limit is a hand-declared constant, and that limit computed from their coefficients.
The others compute theirs from their coefficients when declared: the explicit tableaux (tests/test_tableau.py),
the compositions (``integrators.composition.Composition.oscillator_stability_limit``), gbs4
(tests/test_extrapolation.py), nystrom4 (tests/test_nystrom4.py)."""


def test_every_fixed_step_limit_is_computed_from_the_coefficients_somewhere() -> None:
    from foucault_bench.integrators.composition import VerletComposition
    from foucault_bench.integrators.explicit_rk import ExplicitRungeKutta

    computed_elsewhere = {name for name in FIXED_STEP
                          if isinstance(REGISTRY[name], (ExplicitRungeKutta, VerletComposition))} | {"gbs4", "nystrom4"}
    assert set(FIXED_STEP) == computed_elsewhere | set(COEFFICIENT_LIMITS), set(FIXED_STEP) ^ (
        computed_elsewhere | set(COEFFICIENT_LIMITS))


@pytest.mark.parametrize("name", sorted(COEFFICIENT_LIMITS))
def test_hand_declared_stability_limits_are_the_coefficients(name: str) -> None:
    """The declared constant is the limit computed from the coefficients (to 1e-9); that it is also where the
    compiled step stops being stable is ``test_measured_stability_limit_is_the_declared_one``."""
    assert REGISTRY[name].stability_limit_kh == pytest.approx(COEFFICIENT_LIMITS[name](), abs=1e-9)


@pytest.mark.parametrize("name", [n for n in FIXED_STEP if REGISTRY[n].rotation_growth_per_step(1.0, 1e-4)])
def test_growth_with_rotation_follows_the_declared_law(name: str) -> None:
    """Within 10 % (the law is first order in ah; measured agreement ~1e-4), at every k·h below the limit."""
    rate_ratio = PARIS_10M.vertical_rate_rad_s / PARIS_10M.pendulum_frequency_rad_s
    for kh in (0.1, 0.5, 1.0, 1.5, 1.9):
        expected = REGISTRY[name].rotation_growth_per_step(kh, rate_ratio) - 1.0
        assert spectral_growth(_matrix(name, kh)) == pytest.approx(expected, rel=0.1), kh
        assert spectral_growth(_matrix(name, kh, NO_ROTATION)) < ROUND_OFF


def test_symplectic_euler_diverges_with_rotation_when_its_growth_law_says() -> None:
    """At kh = 1.96 (L = 10 m, Paris) the growing mode takes ln(R/A₀)/ln g steps to carry the bob from its
    amplitude share A₀ ≈ A/2 to the divergence radius R = 1000 L; without rotation it stays bounded."""
    kh = 1.96
    h = kh / PARIS_10M.pendulum_frequency_rad_s
    rate_ratio = PARIS_10M.vertical_rate_rad_s / PARIS_10M.pendulum_frequency_rad_s
    growth = get_integrator("symplectic_euler").rotation_growth_per_step(kh, rate_ratio)
    predicted = math.log(1000 * PARIS_10M.length_m / (0.5 * PARIS_10M.amplitude_m)) / math.log(growth)
    n_steps = int(1.5 * predicted)
    solutions = {}
    for label, params in (("rotation", PARIS_10M), ("none", NO_ROTATION)):
        problem = Problem(MODELS["linear"], params, np.linspace(0.0, n_steps * h, 11))
        solutions[label] = get_integrator("symplectic_euler").solve(problem, step_s=h)
    assert solutions["none"].status == "ok"
    assert solutions["rotation"].status == "diverged"
    assert 0.8 * predicted < solutions["rotation"].steps < 1.2 * predicted


def test_composition_order_conditions_include_the_coupled_ones() -> None:
    """``Composition`` checks every order condition of its declared order, not only the power sums Σγᵏ = 0
    (integrators/composition.py): a symmetric seven-stage composition whose Σγ³ and Σγ⁵ vanish (solved for
    γ₁ = ½) but whose coupled condition of weight 5 does not is refused at order 6, though it is of
    order 4 (the words Y₁Y₁Y₃, Y₁Y₃Y₁, Y₃Y₁Y₁: the commutator [Y₁, [Y₁, Y₃]]); Yoshida's triple jump of triple
    jumps (9 stages) meets all conditions of order 6 and not those of 8;
    the built-in compositions meet theirs (residuals at most a few ulp) and not those of the next order."""
    from foucault_bench.integrators.composition import order_condition_residuals
    from foucault_bench.integrators.methods.composition8 import S15_ORDER8
    from foucault_bench.integrators.methods.composition10 import SOFRONIOU_SPALETTA_S35ODR10

    inner = (0.5, -0.8580459421026114, 0.37367931617363953)
    weights = (*inner, 1.0 - 2.0 * sum(inner), *reversed(inner))
    assert abs(sum(g**3 for g in weights)) < 1e-14 and abs(sum(g**5 for g in weights)) < 1e-14
    assert Composition(weights=weights, order=4).order == 4
    with pytest.raises(ValueError, match=r"order 6 needs the coupled condition of Y\(1, 1, 3\)"):
        Composition(weights=weights, order=6)
    outer = 1.0 / (2.0 - 2.0 ** 0.2)  # the triple jump raising order 4 to 6 (Yoshida 1990, eq. (4.14))
    suzuki = tuple(a * b for a in (outer, 1.0 - 2.0 * outer, outer) for b in triple_jump(4).weights)
    assert Composition(weights=suzuki, order=6).stages == 9
    with pytest.raises(ValueError, match="order 8 needs"):
        Composition(weights=suzuki, order=8)
    for composition in (S15_ORDER8, SOFRONIOU_SPALETTA_S35ODR10):
        residuals = order_condition_residuals(composition.weights, composition.order)
        assert max(abs(value) for value in residuals.values()) < 1e-15
        next_order = order_condition_residuals(composition.weights, composition.order + 1)
        assert max(abs(value) for value in next_order.values()) > 1e-7
    with pytest.raises(ValueError, match="order 10 needs"):
        Composition(weights=S15_ORDER8.weights, order=10)


def test_composition_weights_validate_themselves() -> None:
    yoshida = triple_jump(4)
    assert yoshida.stages == 3 and sum(yoshida.weights) == pytest.approx(1.0, abs=1e-15)
    with pytest.raises(ValueError, match="symmetric"):
        Composition(weights=(0.5, 0.3, 0.2), order=2)
    with pytest.raises(ValueError, match="sum to 1"):
        Composition(weights=(0.4, 0.4), order=2)
    outer, middle, _ = yoshida.weights
    with pytest.raises(ValueError, match="Σγ\\^3"):
        Composition(weights=(outer + 1e-9, 1.0 - 2 * (outer + 1e-9), outer + 1e-9), order=4)
