"""``gbs4``: the extrapolated midpoint rule at fixed order 4 and fixed step (``integrators.extrapolation``).

Each step H computes two lines of the Gragg-Bulirsch-Stoer table, the smoothed explicit midpoint rule with
n = 2 and 4 substeps (the harmonic sequence), and takes T₂₂ = (4 T₂₁ − T₁₁)/3 (Hairer, Nørsett & Wanner, Solving
ODEs I, 2nd ed., §II.9; Gragg, SIAM J. Numer. Anal. 2, 384 (1965); Bulirsch & Stoer, Numer. Math. 8, 1
(1966)). Order 4, 1 + 2 + 4 = 7 evaluations per step; not symplectic, not symmetric. This is the "extrapolation
at fixed order" whose observed order the conformance checks measure; the adaptive code with order and step
control is ``gbs``. Higher fixed orders lose their order on the damped pendulum at measurable steps
(integrators/README.md "Gragg-Bulirsch-Stoer extrapolation").

Stability: on the undamped oscillator the one-step map's spectral radius is |R(ikH)| with R the stability
polynomial of T₂₂, R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 + z⁵/192, below 1 up to kH = 3.36359 (the smallest positive
root of |R(iy)|² − 1, ``integrators.extrapolation.oscillator_stability_limit``), beyond RK4's 2√2. Its phase
lags by arg R(iy) − y = −y⁵/320 + O(y⁷) per step (R(z) − e^z = −z⁵/320 + …), so the swing frequency is low by
(kH)⁴/320 and, by the argument given for RK4 in integrators/README.md, the precession is too slow by (kH)⁴/64.
"""

from typing import ClassVar

from foucault_bench.integrators.extrapolation import HARMONIC, FixedOrderExtrapolation, step_numbers
from foucault_bench.integrators.registry import register

OSCILLATOR_STABILITY_LIMIT_KH = 3.3635
"""The first kH at which |R(ikH)| exceeds 1 (3.363586, rounded down; checked against the polynomial by the tests)."""


@register
class Gbs4(FixedOrderExtrapolation):
    name: ClassVar[str] = "gbs4"
    step_numbers: ClassVar[tuple[int, ...]] = step_numbers(HARMONIC, 2)
    stability_limit_kh: ClassVar[float | None] = OSCILLATOR_STABILITY_LIMIT_KH
    reference: ClassVar[str] = ("Hairer, Nørsett & Wanner, Solving ODEs I, §II.9; Gragg, SIAM J. Numer. Anal. 2, 384 "
                                "(1965); Bulirsch & Stoer, Numer. Math. 8, 1 (1966)")
