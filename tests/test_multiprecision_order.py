"""The order check in 34 digits (``bench.gate.multiprecision_order``) of the pairs whose main methods are known
exactly (``ButcherTableau.exact``): the exact coefficients are those the compiled code rounds, the 34-digit
stepper steps the same method as the compiled fixed-step loop, a pair declaring the wrong order fails, and
``vern7`` and ``vern9`` hold their orders within ``ORDER_TOLERANCE`` on the drag and drive models, where
``vern7``'s main method in double stays at 7.14 (the other models: tests/test_selftest.py)."""

from __future__ import annotations

import dataclasses
import re
from fractions import Fraction
import mpmath
import numpy as np
import pytest

from foucault_bench.bench.gate.conformance import ORDER_TOLERANCE, check_order
from foucault_bench.bench.gate.multiprecision_order import DIGITS, final_position, measure_exact_order
from foucault_bench.bench.gate.order_sweep import ROUND_OFF_PER_EVALUATION, order_parameters
from foucault_bench.integrators import Problem, get_integrator
from foucault_bench.integrators.tableau import ButcherTableau, ExactCoefficients
from foucault_bench.models import MODELS

EXACT_PAIRS = ("vern7", "vern9")


def test_the_pairs_built_from_published_digits_carry_them_exactly() -> None:
    """vern7 and vern9 keep their main methods' exact values (the tableau checked that they round to its
    doubles); the pairs given as doubles do not."""
    for name in EXACT_PAIRS:
        tableau = get_integrator(name).tableau
        assert tableau.exact is not None and len(tableau.exact.b) == tableau.stages
        assert tuple(float(x) for x in tableau.exact.b) == tableau.b
        assert sum(tableau.exact.b) == 1  # the first order condition, exactly
    for name in ("dopri5", "dop853", "tsit5"):
        assert get_integrator(name).tableau.exact is None


def test_exact_values_that_do_not_round_to_the_doubles_are_refused() -> None:
    tableau = get_integrator("vern7").tableau
    assert tableau.exact is not None
    b = list(tableau.exact.b)
    b[-1] += Fraction(1, 10**12)  # a digit mistyped in the twelfth place of the last weight
    with pytest.raises(ValueError, match="exact coefficients: b does not round to the tableau's doubles"):
        dataclasses.replace(tableau, exact=dataclasses.replace(tableau.exact, b=tuple(b)))


def test_a_tableau_without_exact_values_cannot_be_stepped_in_34_digits() -> None:
    with pytest.raises(ValueError, match="no exact coefficients"):
        measure_exact_order(get_integrator("tsit5").tableau, MODELS["linear"])


@pytest.mark.parametrize("model_name", ["linear", "anisotropic_spherical"])
@pytest.mark.parametrize("name", EXACT_PAIRS)
def test_the_34_digit_stepper_steps_the_compiled_main_method(name: str, model_name: str) -> None:
    """At 20 steps (kh ≈ 0.35, errors 1e-6-1e-8 of the amplitude) the final positions of the 34-digit stepper and
    of the compiled fixed-step loop stepping the pair's c, A and b (``fixed_step_method``) differ by no more than
    the compiled run's pessimistic round-off bound, ε per evaluation: a different method would differ by its
    truncation error, 1e-6 and more."""
    model = MODELS[model_name]
    params = order_parameters(model)
    duration_s = 1.125 * params.small_swing_period_s
    problem = Problem(model, params, np.array([0.0, duration_s]))
    compiled = get_integrator(name).fixed_step_method()
    assert compiled is not None
    solution = compiled.solve(problem, step_s=duration_s / 20, monitor=False)
    with mpmath.workdps(DIGITS):
        x, y = final_position(get_integrator(name).tableau, problem, 20)
        gap = float(mpmath.hypot(x - solution.y[-1, 0], y - solution.y[-1, 1])) / params.amplitude_m
    assert solution.steps == 20 and gap <= ROUND_OFF_PER_EVALUATION * solution.nfev, (gap, solution.nfev)


@pytest.mark.parametrize("model_name", ["damped_linear", "driven_linear"])
@pytest.mark.parametrize("name", EXACT_PAIRS)
def test_the_pairs_hold_their_orders_in_34_digits_on_the_drag_and_drive_models(name: str, model_name: str) -> None:
    integrator = get_integrator(name)
    measured = measure_exact_order(integrator.tableau, MODELS[model_name])
    assert abs(measured.order - integrator.order) <= ORDER_TOLERANCE, measured
    check = check_order(integrator, MODELS[model_name])
    assert check.holds and "34-digit arithmetic" in check.detail, check.detail


def test_a_pair_that_understates_its_order_fails_the_check() -> None:
    """vern9's tableau declared as order 8 is a valid tableau (its conditions up to order 8 hold), so only the
    measurement can catch the declaration: observed ≈ 9."""
    vern9 = type(get_integrator("vern9"))
    understated: ButcherTableau = dataclasses.replace(vern9.tableau, order=8)
    attributes: dict[str, object] = {"name": "vern9_declared_8", "order": 8, "tableau": understated}
    mutant = type("Vern9DeclaredEight", (vern9,), attributes)()
    check = check_order(mutant, MODELS["linear"])
    assert check.holds is False and re.match(r"observed order (8\.9|9\.0)\d", check.detail), check.detail


def test_the_exact_coefficients_type_is_plain_data() -> None:
    exact = ExactCoefficients(c=(Fraction(0),), a=((Fraction(0),),), b=(Fraction(1),))
    assert exact.rounding_problems((0.0,), ((0.0,),), (1.0,)) == []
    assert exact.rounding_problems((0.0,), ((0.0,),), (0.5,)) == ["exact coefficients: b does not round to the "
                                                                   "tableau's doubles"]
