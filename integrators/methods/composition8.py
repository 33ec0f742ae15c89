"""Eighth-order composition of the rotating-frame Verlet step: Kahan and Li's seventeen-stage method s17odr8a.

Φ_h = V_{γ₁₇h} ∘ … ∘ V_{γ₁h} with the symmetric weights below, V the rotating-frame Verlet step
(``integrators.methods.verlet``): symplectic, symmetric, order 8, 17 Verlet steps (34 force evaluations) per step.
Kahan and Li's eighth-order methods have 15 (s15odr8) or 17 (s17odr8a, s17odr8b) stages; s17odr8a spends two
stages more than the minimum on a smaller leading error term, and it is the eighth-order method Hairer, Lubich
& Wanner print (Kahan & Li, Math. Comp. 66, 1089 (1997), s17odr8a; weights as in
Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §V.3.2, eq. (3.13)). The weights sum to 1
and Σγ³ = Σγ⁵ = Σγ⁷ = 0 to round-off (checked by ``Composition``); the observed order, 8, is measured by
``foucault-bench selftest composition8`` and tests/test_new_methods.py.
"""

from typing import ClassVar

from foucault_bench.integrators.composition import Composition, VerletComposition
from foucault_bench.integrators.registry import register

_HALF = (
    0.13020248308889008087881763,
    0.56116298177510838456196441,
    -0.38947496264484728640807860,
    0.15884190655515560089621075,
    -0.39590389413323757733623154,
    0.18453964097831570709183254,
    0.25837438768632204729397911,
    0.29501172360931029887096624,
)
KAHAN_LI_S17ODR8A = Composition(weights=(*_HALF, -0.60550853383003451169892108, *reversed(_HALF)), order=8)


@register
class Composition8(VerletComposition):
    name: ClassVar[str] = "composition8"
    composition: ClassVar[Composition] = KAHAN_LI_S17ODR8A
    remainder_sweeps: ClassVar[int] = 8  # symmetric beyond order 8 on the seed's velocity-dependent force
    reference: ClassVar[str] = (
        "Kahan & Li, Math. Comp. 66, 1089 (1997), s17odr8a; Hairer, Lubich & Wanner, Geometric Numerical "
        "Integration, 2nd ed., §V.3.2"
    )
