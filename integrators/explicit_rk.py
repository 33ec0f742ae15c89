"""Fixed-step explicit Runge-Kutta methods from their Butcher tableau: one compiled step per tableau.

A subclass of ``ExplicitRungeKutta`` declares a ``ButcherTableau`` (``integrators.tableau``, validated against its
order conditions when it is built); ``order`` and ``stages`` follow from it. The step is generated from the
coefficients and compiled by numba: straight-line code over scalars, one acceleration call per stage, no array
and no loop over the tableau at run time, so the fixed-step loop (``integrators.fixed_step``) runs it as fast as
the hand-written steps it replaces (bench/PERF.md).

For a second-order system y = (q, v), f(y) = (v, a(q, v)), stage i of an explicit method is
Qᵢ = q + h Σⱼ aᵢⱼ Vⱼ, Vᵢ = v + h Σⱼ aᵢⱼ A(Qⱼ, Vⱼ) with V₁ = v, and the step is q + h Σᵢ bᵢ Vᵢ,
v + h Σᵢ bᵢ A(Qᵢ, Vᵢ) (Hairer, Nørsett & Wanner, Solving ODEs I, §II.1, eq. (1.8)).

Operation order: a row whose coefficients are fractions with a small common denominator D (every classical
method's) is computed as (h / D) · (n₁k₁ + n₂k₂ + …) with integer numerators (each h / D once per step, at the
top, as the C reference computes it), summed left to right, and terms with
a zero coefficient left out; other rows as h · (a₁k₁ + a₂k₂ + …). For explicit Euler and RK4 this is, operation for
operation, the arithmetic of the hand-written steps they had (multiplications by 1, 2 and ½ are exact), so their
results are bitwise the same (tests/test_fixed_step.py).
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.tableau import ButcherTableau
from foucault_bench.models import Model
from foucault_bench.models.jit import jit

MAX_DENOMINATOR = 10_000
"""Largest common denominator of a row written as (h / D) · (integer combination); larger ones use the floats."""


def rational_row(coefficients: tuple[float, ...]) -> tuple[int, tuple[float, ...]]:
    """(D, numerators) with coefficients = numerators / D exactly in double precision, D ≤ ``MAX_DENOMINATOR``;
    (1, coefficients) when there is no such D."""
    fractions = [Fraction(value).limit_denominator(MAX_DENOMINATOR) for value in coefficients]
    if any(float(fraction) != value for fraction, value in zip(fractions, coefficients, strict=True)):
        return 1, tuple(coefficients)
    denominator = math.lcm(*(fraction.denominator for fraction in fractions)) if fractions else 1
    if denominator > MAX_DENOMINATOR:
        return 1, tuple(coefficients)
    return denominator, tuple(float(fraction * denominator) for fraction in fractions)


def _combination(base: str | None, terms: list[str], coefficients: tuple[float, ...]) -> str:
    """Source of ``base`` + h Σⱼ coefficientsⱼ · termsⱼ in the operation order of the module docstring (``None``:
    the increment h Σⱼ coefficientsⱼ · termsⱼ alone)."""
    denominator, weights = rational_row(coefficients)
    products = [term if weight == 1.0 else f"{weight!r} * {term}"
                for term, weight in zip(terms, weights, strict=True) if weight != 0.0]
    if not products:
        return "0.0" if base is None else base
    scale = "h" if denominator == 1 else f"h_over_{denominator}"
    single_term = len(products) == 1 and " " not in products[0]
    total = products[0] if single_term else f"({' + '.join(products)})"
    return f"{scale} * {total}" if base is None else f"{base} + {scale} * {total}"


def step_source(tableau: ButcherTableau, increment: bool = False) -> str:
    """Python source of ``make(acceleration)``, returning the tableau's step ``(x, y, vx, vy, h, p) -> state``, or
    with ``increment`` its increment ``-> (dx, dy, dvx, dvy)``: the same expressions without the added state, so
    that state + increment is the step bit for bit."""
    a = tableau.a
    function = "increment" if increment else "step"
    lines = ["def make(acceleration):", f"    def {function}(x, y, vx, vy, h, p):"]
    velocity_x: list[str] = ["vx"]
    velocity_y: list[str] = ["vy"]
    accel_x: list[str] = []
    accel_y: list[str] = []
    for i in range(tableau.stages):
        if i > 0:
            row = tuple(float(value) for value in a[i][:i])
            for name, base, terms in ((f"x{i}", "x", velocity_x), (f"y{i}", "y", velocity_y),
                                      (f"vx{i}", "vx", accel_x), (f"vy{i}", "vy", accel_y)):
                lines.append(f"        {name} = {_combination(base, terms, row)}")
            velocity_x.append(f"vx{i}")
            velocity_y.append(f"vy{i}")
            arguments = f"x{i}, y{i}, vx{i}, vy{i}"
        else:
            arguments = "x, y, vx, vy"
        lines.append(f"        ax{i}, ay{i} = acceleration({arguments}, p)")
        accel_x.append(f"ax{i}")
        accel_y.append(f"ay{i}")
    weights = tuple(float(value) for value in tableau.b)
    updated = [_combination(None if increment else base, terms, weights) for base, terms in
               (("x", velocity_x), ("y", velocity_y), ("vx", accel_x), ("vy", accel_y))]
    lines += [f"        return {', '.join(updated)}", f"    return {function}"]
    scales = sorted({int(name[len("h_over_"):]) for line in lines for name in line.replace("(", " ").split()
                     if name.startswith("h_over_")})
    lines[2:2] = [f"        h_over_{denominator} = h / {float(denominator)!r}" for denominator in scales]
    return "\n".join(lines) + "\n"


def tableau_step(tableau: ButcherTableau, acceleration: Callable, increment: bool = False) -> Callable:
    """The compiled step (``increment``: its increment, ``step_source``) of ``tableau`` around the model's
    ``acceleration(x, y, vx, vy, p) -> (ax, ay)``.

    The source is compiled under this file's name, so that numba's disk cache (``models.jit``) can locate it; its
    key covers the generated bytecode and constants, hence the coefficients."""
    namespace: dict[str, object] = {"__name__": __name__}
    exec(compile(step_source(tableau, increment), __file__, "exec"), namespace)  # noqa: S102 - source generated above
    make = namespace["make"]
    assert callable(make)
    return jit(make(acceleration))


class ExplicitRungeKutta(FixedStepIntegrator):
    """Base of the fixed-step explicit Runge-Kutta methods: a subclass declares ``tableau`` (``order`` and
    ``stages`` follow from it), ``name``, ``stability_limit_kh`` and ``reference``."""

    tableau: ClassVar[ButcherTableau]
    family: ClassVar[str] = "runge-kutta"
    compensated_update: ClassVar[bool] = True
    """The loop adds the step's increment to the state with compensated summation (``integrators.fixed_step``):
    1.01-1.08× the loop's time for Heun's method and RK4 (bench/PERF.md "Round-off"); ``False`` where it costs more
    than 10 %, and in a subclass that replaces ``make_step`` (the loop would advance by the tableau's increment)."""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "tableau" in cls.__dict__:
            cls.order = cls.tableau.order
            cls.stages = cls.tableau.stages

    def make_step(self, model: Model) -> Callable:
        return tableau_step(self.tableau, model.numba_acceleration)

    def make_increment(self, model: Model) -> Callable | None:
        return tableau_step(self.tableau, model.numba_acceleration, increment=True) if self.compensated_update else None
