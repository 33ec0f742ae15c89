"""Classic fourth-order Runge-Kutta (Kutta 1901), Butcher tableau c = (0, ½, ½, 1), b = (1, 2, 2, 1)/6.

Order 4, 4 stages. Stable on the undamped oscillator for kh ≤ 2√2 ≈ 2.828 (the imaginary-axis stability
boundary); the energy decays by about (kh)⁶/72 per step and the precession is too slow by about (kh)⁴/24
(integrators/README.md "Fixed-step methods on this problem"; Hairer, Nørsett & Wanner, Solving ODEs I, §II.1;
Hairer & Wanner, Solving ODEs II, §IV.2, Fig. 2.1). Stepped from its tableau (``integrators.explicit_rk``).
"""

from typing import ClassVar

from foucault_bench.integrators.explicit_rk import ExplicitRungeKutta
from foucault_bench.integrators.registry import register
from foucault_bench.integrators.tableau import ButcherTableau

TWO_SQRT_TWO = 2.8284271247461903

TABLEAU = ButcherTableau(
    name="rk4",
    c=(0.0, 1 / 2, 1 / 2, 1.0),
    a=(
        (0.0, 0.0, 0.0, 0.0),
        (1 / 2, 0.0, 0.0, 0.0),
        (0.0, 1 / 2, 0.0, 0.0),
        (0.0, 0.0, 1.0, 0.0),
    ),
    b=(1 / 6, 1 / 3, 1 / 3, 1 / 6),
    order=4,
    reference="Kutta, Z. Math. Phys. 46, 435 (1901); Hairer, Nørsett & Wanner, Solving ODEs I, §II.1",
)


@register
class RK4(ExplicitRungeKutta):
    name: ClassVar[str] = "rk4"
    tableau: ClassVar[ButcherTableau] = TABLEAU
    stability_limit_kh: ClassVar[float] = TWO_SQRT_TWO
    reference: ClassVar[str] = TABLEAU.reference
