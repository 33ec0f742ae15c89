"""Symplectic (semi-implicit) Euler, velocity first: v_{n+1} = v_n + h a(x_n, v_n), x_{n+1} = x_n + h v_{n+1}.

Order 1, 1 stage. For a separable Hamiltonian (velocity-free force) it is symplectic, stable for kh < 2 on
the oscillator, and keeps the energy error bounded: this is the behaviour the seed note describes for its
"Euler" solution (Hairer, Lubich & Wanner, Geometric Numerical Integration, §I.1.2 and Thm. VI.3.3). The
Coriolis acceleration here is taken explicitly at v_n, so with rotation the map is only nearly symplectic;
its error is first order either way (Euler–Cromer; Cromer, Am. J. Phys. 49, 455, 1981).
"""

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

    def make_step(self, model: Model) -> Callable:
        acceleration = model.numba_acceleration

        @jit
        def step(x, y, vx, vy, h, p):
            ax, ay = acceleration(x, y, vx, vy, p)
            vx_new = vx + h * ax
            vy_new = vy + h * ay
            return x + h * vx_new, y + h * vy_new, vx_new, vy_new

        return step
