"""Deliberately wrong integrators for ``tests/test_check.py``: the CI gate (``foucault-bench check``) must catch them.

This module is a matrix plug-in (``plugins = ["check_mutants"]``): importing it registers the mutants, in the
test process and in every worker process the runner spawns (the workers import a matrix's plug-ins before
running). It is deliberately not named ``test_*`` so that pytest does not import it while collecting, which
would leave the mutants in the registry for every other test; the test unregisters them when it is done.

* ``rk4_wrong_weights``: classic RK4 with the weights b = (1, 3, 1, 1)/6 instead of (1, 2, 2, 1)/6. They still
  sum to 1 and satisfy Σbᵢcᵢ = 1/2 and Σbᵢcᵢ² = 1/3, but Σbᵢaᵢⱼcⱼ = 1/8 ≠ 1/6 (Butcher's order conditions;
  Hairer, Nørsett & Wanner, Solving ODEs I, §II.2), so the method is of order 2, not 4: a plausible typo that
  still gives a stable, convergent integrator with no obviously wrong output.
* ``verlet_naive_coriolis``: velocity Verlet with the velocity-dependent Coriolis force evaluated explicitly in
  both half kicks, the scheme integrators/README.md "Rotating-frame Verlet" warns against: neither symplectic nor
  volume-preserving, it opens the swing into an ellipse and lets the energy drift.
"""

from typing import Callable, ClassVar

from numba import njit

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.registry import register
from foucault_bench.integrators.methods.rk4 import RK4
from foucault_bench.models import Model

MUTANT_NAMES = ("rk4_wrong_weights", "verlet_naive_coriolis")


@register
class RK4WrongWeights(RK4):
    name: ClassVar[str] = "rk4_wrong_weights"
    reference: ClassVar[str] = "mutant of integrators.methods.rk4 for tests/test_check.py: weights (1, 3, 1, 1)/6"
    compensated_update: ClassVar[bool] = False  # the loop advances by make_step, not by RK4's tableau increment

    def make_step(self, model: Model) -> Callable:
        acceleration = model.numba_acceleration

        @njit(cache=True)
        def step(x, y, vx, vy, h, p):
            half = 0.5 * h
            k1ax, k1ay = acceleration(x, y, vx, vy, p)
            vx2 = vx + half * k1ax
            vy2 = vy + half * k1ay
            k2ax, k2ay = acceleration(x + half * vx, y + half * vy, vx2, vy2, p)
            vx3 = vx + half * k2ax
            vy3 = vy + half * k2ay
            k3ax, k3ay = acceleration(x + half * vx2, y + half * vy2, vx3, vy3, p)
            vx4 = vx + h * k3ax
            vy4 = vy + h * k3ay
            k4ax, k4ay = acceleration(x + h * vx3, y + h * vy3, vx4, vy4, p)
            sixth = h / 6.0
            return (
                x + sixth * (vx + 3.0 * vx2 + vx3 + vx4),
                y + sixth * (vy + 3.0 * vy2 + vy3 + vy4),
                vx + sixth * (k1ax + 3.0 * k2ax + k3ax + k4ax),
                vy + sixth * (k1ay + 3.0 * k2ay + k3ay + k4ay),
            )

        return step


@register
class VerletNaiveCoriolis(FixedStepIntegrator):
    name: ClassVar[str] = "verlet_naive_coriolis"
    family: ClassVar[str] = "verlet"
    order: ClassVar[int] = 2
    stages: ClassVar[int] = 2
    stability_limit_kh: ClassVar[float] = 2.0
    reference: ClassVar[str] = "mutant for tests/test_check.py: velocity Verlet with explicit Coriolis kicks"

    def make_step(self, model: Model) -> Callable:
        acceleration = model.numba_acceleration

        @njit(cache=True)
        def step(x, y, vx, vy, h, p):
            ax, ay = acceleration(x, y, vx, vy, p)
            vx_half = vx + 0.5 * h * ax
            vy_half = vy + 0.5 * h * ay
            x_new = x + h * vx_half
            y_new = y + h * vy_half
            ax, ay = acceleration(x_new, y_new, vx_half, vy_half, p)
            return x_new, y_new, vx_half + 0.5 * h * ax, vy_half + 0.5 * h * ay

        return step
