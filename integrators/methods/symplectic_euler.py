"""Symplectic (semi-implicit) Euler, velocity first: v_{n+1} = v_n + h a(x_n, v_n), x_{n+1} = x_n + h v_{n+1}.

Order 1, 1 stage. For a separable Hamiltonian (velocity-free force) it is symplectic, stable for kh < 2 on
the oscillator, and keeps the energy error bounded: this is the behaviour the seed note describes for its
"Euler" solution (Hairer, Lubich & Wanner, Geometric Numerical Integration, §I.1.2 and Thm. VI.3.3); its error
is first order (Euler–Cromer; Cromer, Am. J. Phys. 49, 455, 1981).

**With Earth's rotation it is unstable at every step size.** The Coriolis acceleration is taken explicitly at
v_n. On the linear model, in complex form u = x + iy, v = u̇, v̇ = −k²u − 2iav (a = Ω_E sin φ), one step is
v' = (1 − 2iah)v − hk²u, u' = u + hv', whose matrix has determinant 1 − 2iah: |det| = √(1 + 4a²h²) > 1, so
one eigenvalue lies outside the unit circle for every h > 0. Perturbing the rotation-free eigenvalues e^{±iθ},
cos θ = 1 − (kh)²/2, to first order in ah gives the growing one

    |λ| ≈ 1 + ah·tan(θ/2) = 1 + ½(kh)²(a/k)/√(1 − (kh/2)²)

(``rotation_growth_per_step``; measured by the stability study). At kh = 1.96, L = 10 m in Paris the amplitude
grows by 5.3e-4 per step and the run diverges after some 2·10⁴ steps; at kh = 0.5 the energy error after
2·10⁴ steps is visibly above its rotation-free oscillation. The declared limit 2 is the rotation-free one.
"""

import math
from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.registry import register
from foucault_bench.models import Model
from foucault_bench.models.jit import jit


@register
class SymplecticEuler(FixedStepIntegrator):
    name: ClassVar[str] = "symplectic_euler"
    family: ClassVar[str] = "euler"
    order: ClassVar[int] = 1
    stages: ClassVar[int] = 1
    stability_limit_kh: ClassVar[float] = 2.0
    reference: ClassVar[str] = "Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §I.1.2"

    def rotation_growth_per_step(self, kh: float, rate_ratio: float) -> float | None:
        half = 0.5 * kh
        return 1.0 + 0.5 * kh * kh * rate_ratio / math.sqrt(1.0 - half * half) if half < 1.0 else math.nan

    def make_step(self, model: Model) -> Callable:
        acceleration = model.numba_acceleration

        @jit
        def step(x, y, vx, vy, h, p):
            ax, ay = acceleration(x, y, vx, vy, p)
            vx_new = vx + h * ax
            vy_new = vy + h * ay
            return x + h * vx_new, y + h * vy_new, vx_new, vy_new

        return step
