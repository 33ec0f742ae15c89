"""Explicit (forward) Euler: y_{n+1} = y_n + h f(y_n), the one-stage tableau c = (0), a = (0), b = (1).

Order 1, 1 stage. On the undamped oscillator its amplification factor is |1 + ikh| > 1 for every h > 0, so
it is unstable at every step size: the energy grows by the factor (1 + (kh)²) per step, E_n/E_0 = (1 + (kh)²)ⁿ
(integrators/README.md "Fixed-step methods on this problem"; Hairer, Nørsett & Wanner, Solving ODEs I, §II.1;
Hairer & Wanner, Solving ODEs II, §IV.2). This is the scheme the seed note used (reports/README.md "The seed
note"); its claim that the energy error stays bounded is false for it. Stepped from its tableau
(``integrators.explicit_rk``).
"""

from typing import ClassVar

from foucault_bench.integrators.explicit_rk import ExplicitRungeKutta
from foucault_bench.integrators.registry import register
from foucault_bench.integrators.tableau import ButcherTableau

TABLEAU = ButcherTableau(
    name="explicit_euler",
    c=(0.0,),
    a=((0.0,),),
    b=(1.0,),
    order=1,
    reference="Euler (1768); Hairer, Nørsett & Wanner, Solving ODEs I, §II.1",
)


@register
class ExplicitEuler(ExplicitRungeKutta):
    name: ClassVar[str] = "explicit_euler"
    family: ClassVar[str] = "euler"
    tableau: ClassVar[ButcherTableau] = TABLEAU
    stability_limit_kh: ClassVar[None] = None
    reference: ClassVar[str] = TABLEAU.reference
    compensated_update: ClassVar[bool] = False
    """Its step is so cheap that compensated summation cost 1.27× on the linear model (bench/PERF.md "Round-off");
    and it is unstable at every step, its error growing far faster than round-off."""
