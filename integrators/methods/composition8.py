"""Eighth-order composition of the rotating-frame Verlet step: the 15-stage symmetric composition of order 8.

Φ_h = V_{γ₁₅h} ∘ … ∘ V_{γ₁h} with the symmetric weights below, V the rotating-frame Verlet step
(``integrators.methods.verlet``): symplectic, symmetric, order 8, 15 Verlet steps (30 force evaluations) per
step. The weights are the 15-stage order-8 solution of McLachlan (SIAM J. Sci. Comput. 16, 151 (1995), after
Suzuki & Umeno (1993), who first gave 15-stage solutions; so both are cited by SUNDIALS ARKODE); digits as in its
table ``ARKODE_SPRK_SUZUKI_UMENO_8_16`` and OrdinaryDiffEq.jl's ``McAte8`` (the same values to 26 digits), and
Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §V.3.2 for the order conditions they meet.
``Composition`` checks every order condition up to 8 when the module is imported (the residuals are at most
2e-16; the first one of order 9, the coefficient of a word of weight 9, is 7.7e-3). Stability limit on the
oscillator: ``Composition.oscillator_stability_limit`` (≈ 3.393: the first kh where |trace| of the product of
the sub-steps' matrices reaches 2, and the set where it stays below 2 is the whole interval (0, 3.393)).
"""

from typing import ClassVar

from foucault_bench.integrators.composition import Composition, VerletComposition
from foucault_bench.integrators.registry import register

_HALF = (
    0.74167036435061295344822780,
    -0.40910082580003159399730010,
    0.19075471029623837995387626,
    -0.57386247111608226665638773,
    0.29906418130365592384446354,
    0.33462491824529818378495798,
    0.31529309239676659663205666,
)
S15_ORDER8 = Composition(weights=(*_HALF, -0.79688793935291635401978884, *reversed(_HALF)), order=8)


@register
class Composition8(VerletComposition):
    name: ClassVar[str] = "composition8"
    composition: ClassVar[Composition] = S15_ORDER8
    remainder_sweeps: ClassVar[int] = 8
    reference: ClassVar[str] = (
        "McLachlan, SIAM J. Sci. Comput. 16, 151 (1995), 15 stages, order 8 (after Suzuki & Umeno 1993); "
        "Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §V.3.2"
    )
