"""The order sweep of ``foucault-bench selftest`` (``bench.gate.conformance``, check 1) for an adaptive pair whose
main method is known to more digits than a double holds (``exact_main_method``: the tableaux of ``vern7`` and
``vern9``, kept with their published digits, ``ButcherTableau.exact``; the general Runge-Kutta-Nyström pair
``fine_rkn5``, in fractions): the main method stepped at fixed steps in 34-digit arithmetic, against heyoka's
Taylor method in quadruple precision.

Why: Verner minimised the leading error coefficients of his pairs, so the next terms of the error expansion hold
the local slopes of a sweep above the order down to double precision's round-off (integrators/README.md
"Verner's pairs (`vern7`, `vern9`)"): in double, ``vern9``'s fits are 9.2-9.5 and ``vern7``'s on the drag and
drive models 7.14; ``fine_rkn5``'s slopes approach 5 from above as slowly (5.13 at 2.7e-14). In 34 digits the
round-off lies near 1e-31 and the sweep runs on to final-position errors of ``FLOOR_ERROR``, where the slopes
have settled (measured on every model: ``vern7`` 7.004-7.011, ``vern9`` 8.979-9.030, ``fine_rkn5`` 5.01; 5.010
and 5.007 on the linear and damped models).

The sweep follows ``bench.gate.order_sweep``'s above order 6, at any order: the same parameters
(``order_parameters``, with the sped-up rotation and the drag and drive models' ellipse), duration
(``ORDER_PERIODS``) and fit (``fit_order``'s: the finest points whose local slopes agree within
``HIGH_ORDER_AGREEMENT``), kh divided by 10^(1/p) from one run to the next (a decade of error per point), from kh =
``UNDECLARED_LIMIT_START_KH`` (errors near 1e-6: no doubling from a finer start is needed, and there is no
round-off to stop at). It stops below ``FLOOR_ERROR``, where the error stops falling (a wrong method's floor; that
point is fitted too, as it carries no round-off), where a run would take more than ``MAX_EXACT_RUN_STEPS`` steps
(a method of much lower order than declared: the check fails, at a bounded cost), or where a run fails (a
non-real state on the sphere: error ∞).

The arithmetic is MPFR's binary floating point at ``PRECISION_BITS`` = 113 bits (IEEE binary128's precision, about
34 significant digits: the reference's), through gmpy2 (Fousse et al., "MPFR: A multiple-precision binary
floating-point library with correct rounding", ACM TOMS 33, 2007): every operation, ``sqrt``, ``sin`` and ``cos``
included, is correctly rounded. Each stage's weighted sum Σⱼ aᵢⱼ kⱼ is the correctly rounded sum (``gmpy2.fsum``) of
the products, each rounded once. The right-hand side is the model's one force source (``Model.acceleration``) over
gmpy2's ``sqrt``, ``sin`` and ``cos``, the source numba and heyoka compile; the release state and the parameters are
the problem's doubles, exact at 113 bits; an invalid operation (the square root of a negative number: the run left
the sphere's domain) raises. The reference, ``final_state_in_quad`` (``integrators.methods.heyoka_taylor``), is
heyoka's Taylor method in IEEE binary128 at tol 1e-33, kept in binary128: about 1e-30 of the amplitude, far below
the floor. Cost: 0.1-0.5 s of CPU per model for Verner's pairs and 1-2 s for ``fine_rkn5`` (the order-5 sweep takes
thousands of steps to reach the floor; each operation is a call from Python into MPFR), plus the reference's
compilation where heyoka's disk cache does not hold it.
"""

from __future__ import annotations

import math
import types
from fractions import Fraction
from typing import Callable

import gmpy2
import numpy as np

from foucault_bench.bench.gate.order_sweep import (
    HIGH_ORDER_AGREEMENT,
    ORDER_PERIODS,
    UNDECLARED_LIMIT_START_KH,
    OrderMeasurement,
    order_parameters,
)
from foucault_bench.bench.verdicts.convergence import observed_order
from foucault_bench.integrators import Integrator, Problem
from foucault_bench.integrators.methods.heyoka_taylor import final_state_in_quad
from foucault_bench.integrators.rkn import NystromPair
from foucault_bench.integrators.tableau import ButcherTableau
from foucault_bench.models import Model, PendulumParameters

ExactMethod = ButcherTableau | NystromPair
"""A main method whose coefficients are known exactly: a tableau with ``exact`` values, or an RKN pair (fractions)."""

PRECISION_BITS = 113
"""The stepper's precision in bits: IEEE binary128's (about 34 significant digits), the reference's."""
DIGITS = 34
"""``PRECISION_BITS`` in decimal digits, as messages say it."""
FLOOR_ERROR = 1e-18
"""The sweep's last error (final position, units of the amplitude): twelve decades above the reference's error, and
where the local slopes of ``vern7`` and ``vern9`` are within 0.03 of their orders on every model (near 1e-15
they are still up to 0.05 off)."""
MAX_EXACT_RUN_STEPS = 20_000
"""The most steps of one 34-digit run (0.1-0.3 ms a step of a 7-stage method): 4.5× the finest run of the
built-in methods (fine_rkn5, 4400 steps at kh 0.0016). A method of much lower order than it declares reaches it
long before the floor and fails the check (``measure_exact_order``'s note says so)."""


def exact_main_method(integrator: Integrator) -> ExactMethod | None:
    """The main method of an adaptive integrator whose coefficients are known exactly: an embedded pair's tableau
    with ``exact`` values (``vern7``, ``vern9``) or a general RKN pair (``pair``: ``fine_rkn5``); None otherwise."""
    if not integrator.adaptive or integrator.order is None:
        return None
    tableau = getattr(integrator, "tableau", None)
    if isinstance(tableau, ButcherTableau) and tableau.exact is not None:
        return tableau
    pair = getattr(integrator, "pair", None)
    return pair if isinstance(pair, NystromPair) else None


def measure_exact_order(method: ExactMethod, model: Model, params: PendulumParameters | None = None,
                        periods: float = ORDER_PERIODS) -> OrderMeasurement:
    """Observed order of the main method of ``method`` (a tableau's exact c, A and b, or an RKN pair) on
    ``model``, stepped in ``DIGITS``-digit arithmetic at fixed steps (see the module docstring); ``ValueError``
    for a tableau without exact coefficients."""
    if isinstance(method, ButcherTableau) and method.exact is None:
        raise ValueError(f"tableau {method.name!r} has no exact coefficients to step in {DIGITS} digits")
    params = order_parameters(model) if params is None else params
    duration = periods * params.small_swing_period_s
    k = params.pendulum_frequency_rad_s
    problem = Problem(model, params, np.array([0.0, duration]))
    ratio = 10.0 ** (1.0 / method.order)
    steps: list[float] = []
    errors: list[float] = []
    note = ""
    with working_precision():
        reference = [gmpy2.mpfr(str(value)) for value in final_state_in_quad(problem)[:2]]
        kh = UNDECLARED_LIMIT_START_KH
        while True:
            n_steps = math.ceil(k * duration / kh)
            if n_steps > MAX_EXACT_RUN_STEPS:
                note = f"stopped at {MAX_EXACT_RUN_STEPS} steps per run"
                break
            try:
                x, y = final_position(method, problem, n_steps)
                error = float(gmpy2.hypot(x - reference[0], y - reference[1])) / params.amplitude_m
            except ValueError:  # gmpy2.InvalidOperationError: the run left the sphere's domain
                error = math.inf
            steps.append(duration / n_steps)
            errors.append(error)
            if error < FLOOR_ERROR or not math.isfinite(error) or (len(errors) > 1 and error >= errors[-2]):
                break
            kh /= ratio
    order = observed_order(steps, errors, agreement=HIGH_ORDER_AGREEMENT)
    return OrderMeasurement(np.array(steps), np.array(errors), order, note)


def working_precision() -> gmpy2.context:
    """The stepper's arithmetic, for a ``with`` block: ``PRECISION_BITS``, rounding to nearest, and an invalid
    operation (``sqrt`` of a negative number) raising ``gmpy2.InvalidOperationError`` (a ``ValueError``) instead of
    giving NaN."""
    return gmpy2.context(precision=PRECISION_BITS, round=gmpy2.RoundToNearest, trap_invalid=True)


def final_position(method: ExactMethod, problem: Problem, n_steps: int) -> tuple[gmpy2.mpfr, gmpy2.mpfr]:
    """(x, y) after ``n_steps`` steps of the exact main method over the problem's span, in gmpy2's current
    context (``working_precision``): a Runge-Kutta tableau's c, A and b (HNW I, §II.1) or a general
    Runge-Kutta-Nyström pair's c, ā, a, b̄ and b (HNW I, §II.14; ``integrators.rkn``). Every model is autonomous
    (``Model.acceleration`` has no t)."""
    math_namespace = types.SimpleNamespace(sqrt=gmpy2.sqrt, sin=gmpy2.sin, cos=gmpy2.cos)
    p = [gmpy2.mpfr(float(value)) for value in problem.parameter_vector]
    model = problem.model

    def acceleration(x, y, vx, vy) -> tuple:
        return model.acceleration(math_namespace, x, y, vx, vy, p)

    h = gmpy2.mpfr(problem.t_end_s) / n_steps
    state = [gmpy2.mpfr(float(value)) for value in problem.initial_state]
    if isinstance(method, NystromPair):
        return _nystrom_steps(method, acceleration, state, h, n_steps)
    exact = method.exact
    assert exact is not None  # measure_exact_order checked it
    rows = _sparse(exact.a)
    weights = _sparse([exact.b])[0]
    for _ in range(n_steps):
        stages: list[tuple] = []
        for row in rows:
            stage = [state[q] + h * _dot(row, stages, q) for q in range(4)]
            stages.append((stage[2], stage[3], *acceleration(*stage)))
        state = [state[q] + h * _dot(weights, stages, q) for q in range(4)]
    return state[0], state[1]


def _nystrom_steps(pair: NystromPair, acceleration: Callable, state: list, h: gmpy2.mpfr,
                   n_steps: int) -> tuple[gmpy2.mpfr, gmpy2.mpfr]:
    """``n_steps`` general RKN steps from ``state``: (x, y) at the end."""
    position_rows, velocity_rows = _sparse(pair.position), _sparse(pair.velocity)
    position_weights, velocity_weights = _sparse([pair.position_weights, pair.velocity_weights])
    nodes = [_rounded(c) for c in pair.c]
    h2 = h * h
    for _ in range(n_steps):
        stages: list[tuple] = []
        for c, position_row, velocity_row in zip(nodes, position_rows, velocity_rows, strict=True):
            position = [state[q] + c * h * state[q + 2] + h2 * _dot(position_row, stages, q) for q in range(2)]
            velocity = [state[q + 2] + h * _dot(velocity_row, stages, q) for q in range(2)]
            stages.append(acceleration(*position, *velocity))
        state = [*(state[q] + h * state[q + 2] + h2 * _dot(position_weights, stages, q) for q in range(2)),
                 *(state[q + 2] + h * _dot(velocity_weights, stages, q) for q in range(2))]
    return state[0], state[1]


def _sparse(rows) -> list[list[tuple[int, gmpy2.mpfr]]]:
    """Each row's non-zero entries as (column, value) in the current precision."""
    return [[(j, _rounded(value)) for j, value in enumerate(row) if value] for row in rows]


def _dot(row: list[tuple[int, gmpy2.mpfr]], stages: list[tuple], component: int) -> gmpy2.mpfr:
    """Σⱼ rowⱼ · stagesⱼ[component] over the row's non-zero entries: the products rounded, their sum rounded once."""
    return gmpy2.fsum([value * stages[j][component] for j, value in row])


def _rounded(value: Fraction) -> gmpy2.mpfr:
    """A rational to the nearest number of the current precision."""
    return gmpy2.mpfr(gmpy2.mpq(value.numerator, value.denominator))
