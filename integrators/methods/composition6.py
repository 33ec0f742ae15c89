"""Sixth-order composition of the rotating-frame Verlet step: Kahan and Li's nine-stage method s9odr6a.

Φ_h = V_{γ₉h} ∘ … ∘ V_{γ₁h} with the symmetric weights below, V the rotating-frame Verlet step
(``integrators.methods.verlet``): symplectic, symmetric, order 6, 9 Verlet steps (18 force evaluations) per step.
Kahan and Li chose the weights to minimise the leading error term; they beat Yoshida's seven-stage sixth-order
solution at equal cost (Kahan & Li, Math. Comp. 66, 1089 (1997); weights as printed in Hairer, Lubich & Wanner,
Geometric Numerical Integration, 2nd ed., §V.3.2, eq. (3.12)).
"""

from typing import ClassVar

from foucault_bench.integrators.composition import Composition, VerletComposition
from foucault_bench.integrators.registry import register

_HALF = (
    0.39216144400731413927925056,
    0.33259913678935943859974864,
    -0.70624617255763935980996482,
    0.08221359629355080023149045,
)
KAHAN_LI_S9ODR6A = Composition(weights=(*_HALF, 0.79854399093482996339895035, *reversed(_HALF)), order=6)


@register
class Composition6(VerletComposition):
    name: ClassVar[str] = "composition6"
    composition: ClassVar[Composition] = KAHAN_LI_S9ODR6A
    reference: ClassVar[str] = (
        "Kahan & Li, Math. Comp. 66, 1089 (1997), s9odr6a; Hairer, Lubich & Wanner, Geometric Numerical "
        "Integration, 2nd ed., §V.3.2"
    )
