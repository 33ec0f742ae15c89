"""Classic fourth-order Runge-Kutta (Kutta 1901), Butcher tableau c = (0, ½, ½, 1), b = (1, 2, 2, 1)/6.

Order 4, 4 stages. Stable on the undamped oscillator for kh ≤ 2√2 ≈ 2.828 (the imaginary-axis stability
boundary); the energy decays by about (kh)⁶/72 per step and the precession is too slow by about (kh)⁴/24
(integrators/README.md "Fixed-step methods on this problem"; Hairer, Nørsett & Wanner, Solving ODEs I, §II.1;
Hairer & Wanner, Solving ODEs II, §IV.2, Fig. 2.1).
"""

from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.registry import register
from foucault_bench.models import Model
from foucault_bench.models.jit import jit

TWO_SQRT_TWO = 2.8284271247461903


@register
class RK4(FixedStepIntegrator):
    name: ClassVar[str] = "rk4"
    family: ClassVar[str] = "runge-kutta"
    order: ClassVar[int] = 4
    stages: ClassVar[int] = 4
    stability_limit_kh: ClassVar[float] = TWO_SQRT_TWO
    reference: ClassVar[str] = "Kutta, Z. Math. Phys. 46, 435 (1901); Hairer, Nørsett & Wanner, Solving ODEs I, §II.1"

    def make_step(self, model: Model) -> Callable:
        acceleration = model.numba_acceleration

        @jit
        def step(x, y, vx, vy, h, p):
            half = 0.5 * h
            k1ax, k1ay = acceleration(x, y, vx, vy, p)
            x2 = x + half * vx
            y2 = y + half * vy
            vx2 = vx + half * k1ax
            vy2 = vy + half * k1ay
            k2ax, k2ay = acceleration(x2, y2, vx2, vy2, p)
            x3 = x + half * vx2
            y3 = y + half * vy2
            vx3 = vx + half * k2ax
            vy3 = vy + half * k2ay
            k3ax, k3ay = acceleration(x3, y3, vx3, vy3, p)
            x4 = x + h * vx3
            y4 = y + h * vy3
            vx4 = vx + h * k3ax
            vy4 = vy + h * k3ay
            k4ax, k4ay = acceleration(x4, y4, vx4, vy4, p)
            sixth = h / 6.0
            return (
                x + sixth * (vx + 2.0 * vx2 + 2.0 * vx3 + vx4),
                y + sixth * (vy + 2.0 * vy2 + 2.0 * vy3 + vy4),
                vx + sixth * (k1ax + 2.0 * k2ax + 2.0 * k3ax + k4ax),
                vy + sixth * (k1ay + 2.0 * k2ay + 2.0 * k3ay + k4ay),
            )

        return step
