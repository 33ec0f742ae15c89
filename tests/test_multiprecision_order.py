"""The order check in 34 digits (``bench.gate.multiprecision_order``) of the adaptive pairs whose main methods are
known exactly: the exact coefficients are those the compiled code rounds, the 34-digit stepper steps the same
method as the compiled fixed-step loop, a pair declaring the wrong order fails, and ``vern7``, ``vern9`` and
``fine_rkn5`` hold their orders within ``ORDER_TOLERANCE`` on ``damped_linear``, where ``vern7``'s main method
in double stays at 7.14 (the other models of the selftest's order check: tests/test_selftest.py)."""

from __future__ import annotations

import dataclasses
import re
from fractions import Fraction

import gmpy2
import numpy as np
import pytest

from foucault_bench.bench.gate.conformance import ORDER_TOLERANCE, check_order
from foucault_bench.bench.gate.multiprecision_order import (
    FLOOR_ERROR,
    exact_main_method,
    final_position,
    measure_exact_order,
    working_precision,
)
from foucault_bench.bench.gate.order_sweep import ROUND_OFF_PER_EVALUATION, order_parameters
from foucault_bench.integrators import Problem, built_in_names, get_integrator
from foucault_bench.integrators.tableau import ExactCoefficients
from foucault_bench.models import MODELS

EXACT_PAIRS = ("vern7", "vern9")


def test_the_pairs_built_from_published_digits_carry_them_exactly() -> None:
    """vern7 and vern9 keep their main methods' exact values, whose weights meet the first order condition
    exactly (the doubles, summed exactly, meet it only to round-off); the pairs given as doubles keep none."""
    for name in EXACT_PAIRS:
        tableau = get_integrator(name).tableau
        assert tableau.exact is not None and len(tableau.exact.b) == tableau.stages
        assert sum(tableau.exact.b) == 1 and sum(Fraction(b) for b in tableau.b) != 1
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
    with working_precision():
        x, y = final_position(get_integrator(name).tableau, problem, 20)
        gap = float(gmpy2.hypot(x - solution.y[-1, 0], y - solution.y[-1, 1])) / params.amplitude_m
    assert solution.steps == 20 and gap <= ROUND_OFF_PER_EVALUATION * solution.nfev, (gap, solution.nfev)


@pytest.mark.parametrize("name", EXACT_PAIRS + ("fine_rkn5",))
def test_the_pairs_hold_their_orders_in_34_digits_on_the_drag_model(name: str) -> None:
    integrator = get_integrator(name)
    method = exact_main_method(integrator)
    assert method is not None
    measured = measure_exact_order(method, MODELS["damped_linear"])
    assert abs(measured.order - integrator.order) <= ORDER_TOLERANCE, measured
    assert measured.errors[-1] < FLOOR_ERROR and np.all(np.diff(measured.errors) < 0), measured


def test_only_the_pairs_known_exactly_are_stepped_in_34_digits() -> None:
    exact = {name for name in built_in_names() if exact_main_method(get_integrator(name)) is not None}
    assert exact == {"vern7", "vern9", "fine_rkn5"}


@pytest.mark.parametrize(("name", "declared"), [("vern9", 8), ("fine_rkn5", 6)])
def test_a_pair_declaring_another_order_fails_the_check(name: str, declared: int) -> None:
    """vern9's tableau declared as order 8 is a valid tableau (its conditions up to order 8 hold), and Fine's pair
    declared as order 6 a valid pair (it checks the simplest conditions only), so only the measurement can catch
    the declaration: observed ≈ 9 and 5."""
    cls = type(get_integrator(name))
    if name == "vern9":
        attributes: dict[str, object] = {"tableau": dataclasses.replace(cls.tableau, order=declared)}
    else:
        attributes = {"pair": dataclasses.replace(cls.pair, order=declared), "order": declared}
    mutant = type(f"{cls.__name__}Declared{declared}", (cls,), {"name": f"{name}_declared_{declared}", **attributes})()
    assert mutant.order == declared
    check = check_order(mutant, MODELS["linear"])
    observed = {"vern9": r"(8\.9|9\.0)\d", "fine_rkn5": r"(4\.9|5\.0)\d"}[name]
    assert check.holds is False and re.match(f"observed order {observed}", check.detail), check.detail


def test_the_exact_coefficients_type_is_plain_data() -> None:
    exact = ExactCoefficients(c=(Fraction(0),), a=((Fraction(0),),), b=(Fraction(1),))
    assert exact.rounding_problems((0.0,), ((0.0,),), (1.0,)) == []
    assert exact.rounding_problems((0.0,), ((0.0,),), (0.5,)) == ["exact coefficients: b does not round to the "
                                                                   "tableau's doubles"]


def test_the_34_digit_nystrom_step_is_the_pair_s_formula() -> None:
    """One 34-digit step of Fine's pair from the release equals the double-precision step of tests/test_rkn.py
    (the formulas of ``integrators.rkn``, written out there) to the doubles' round-off: 1e-15 of the amplitude,
    where a wrong coefficient or term (c·h·ṙ left out, ā read as a) moves it by the local error, 1e-7 and more."""
    from test_rkn import FAST, one_step

    from foucault_bench.integrators.methods.fine_rkn5 import PAIR

    h = 0.2 / FAST.pendulum_frequency_rad_s
    problem = Problem(MODELS["linear"], FAST, np.array([0.0, h]))
    in_double = one_step(FAST, h)[0]
    with working_precision():
        x, y = final_position(PAIR, problem, 1)
        gap = float(gmpy2.hypot(x - in_double[0], y - in_double[1])) / FAST.amplitude_m
    assert gap <= 1e-15, gap
