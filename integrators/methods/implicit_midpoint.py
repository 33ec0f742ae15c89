"""Implicit midpoint rule: y₁ = y₀ + h f((y₀ + y₁)/2), the one-stage Gauss–Legendre method.

Order 2, symmetric, symplectic, conserves quadratic invariants exactly (the linear model's energy to
round-off); one force evaluation per fixed-point sweep, several sweeps per step (``integrators.gauss`` for the
solve and its limit kh < 2). Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §I.1.3 and
§VI.3; Cooper, IMA J. Numer. Anal. 7, 1 (1987).
"""

from typing import ClassVar

from foucault_bench.integrators.gauss import GaussCollocation
from foucault_bench.integrators.registry import register


@register
class ImplicitMidpoint(GaussCollocation):
    name: ClassVar[str] = "implicit_midpoint"
    order: ClassVar[int] = 2
    collocation_stages: ClassVar[int] = 1
    stability_limit_kh: ClassVar[float] = 2.0
    reference: ClassVar[str] = (
        "Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §I.1.3, §VI.3, §VIII.6"
    )
