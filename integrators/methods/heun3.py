"""Heun's third-order method (Heun 1900), Butcher tableau c = (0, ⅓, ⅔), a₂₁ = ⅓, a₃₂ = ⅔, b = (1, 0, 3)/4.

Order 3, 3 stages. Every 3-stage method of order 3 has the stability function R(z) = 1 + z + z²/2 + z³/6; on the
undamped oscillator |R(iy)|² = 1 − y⁴/12 + y⁶/36 with y = kh, so it is stable for kh ≤ √3 ≈ 1.732 and the energy
decays by about (kh)⁴/12 per step (Hairer, Nørsett & Wanner, Solving ODEs I, §II.1, Table 1.1; Hairer & Wanner,
Solving ODEs II, §IV.2). Stepped from its tableau (``integrators.explicit_rk``).
"""

from typing import ClassVar

from foucault_bench.integrators.explicit_rk import ExplicitRungeKutta
from foucault_bench.integrators.registry import register
from foucault_bench.integrators.tableau import ButcherTableau

SQRT_THREE = 1.7320508075688772

TABLEAU = ButcherTableau(
    name="heun3",
    c=(0.0, 1 / 3, 2 / 3),
    a=(
        (0.0, 0.0, 0.0),
        (1 / 3, 0.0, 0.0),
        (0.0, 2 / 3, 0.0),
    ),
    b=(1 / 4, 0.0, 3 / 4),
    order=3,
    reference="Heun, Z. Math. Phys. 45, 23 (1900); Hairer, Nørsett & Wanner, Solving ODEs I, §II.1, Table 1.1",
)


@register
class Heun3(ExplicitRungeKutta):
    name: ClassVar[str] = "heun3"
    tableau: ClassVar[ButcherTableau] = TABLEAU
    stability_limit_kh: ClassVar[float] = SQRT_THREE
    reference: ClassVar[str] = TABLEAU.reference
