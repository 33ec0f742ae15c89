"""Explicit (forward) Euler: y_{n+1} = y_n + h f(y_n).

Order 1, 1 stage. On the undamped oscillator its amplification factor is |1 + ikh| > 1 for every h > 0, so
it is unstable at every step size: the energy grows by the factor (1 + (kh)²) per step, E_n/E_0 = (1 + (kh)²)ⁿ
(integrators/README.md "Fixed-step methods on this problem"; Hairer, Nørsett & Wanner, Solving ODEs I, §II.1;
Hairer & Wanner, Solving ODEs II, §IV.2). This is the scheme the seed note used (reports/README.md "The seed
note"); its claim that the energy error stays bounded is false for it.
"""

from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.registry import register
from foucault_bench.models import Model
from foucault_bench.models.jit import jit


@register
class ExplicitEuler(FixedStepIntegrator):
    name: ClassVar[str] = "explicit_euler"
    family: ClassVar[str] = "euler"
    order: ClassVar[int] = 1
    stages: ClassVar[int] = 1
    stability_limit_kh: ClassVar[None] = None
    reference: ClassVar[str] = "Euler (1768); Hairer, Nørsett & Wanner, Solving ODEs I, §II.1"

    def make_step(self, model: Model) -> Callable:
        acceleration = model.numba_acceleration

        @jit
        def step(x, y, vx, vy, h, p):
            ax, ay = acceleration(x, y, vx, vy, p)
            return x + h * vx, y + h * vy, vx + h * ax, vy + h * ay

        return step
