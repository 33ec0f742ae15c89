"""Nyström's fourth-order method for the general second-order equation r̈ = f(t, r, ṙ), fixed step.

A Runge-Kutta-Nyström method integrates the second-order equation directly: the stages carry a position and a
velocity, and the position is advanced with the h² weights b̄ (Nyström, Acta Soc. Sci. Fenn. 50, No. 13
(1925); Hairer, Nørsett & Wanner, Solving ODEs I, 2nd ed., §II.14, the general case y'' = f(x, y, y')).
Here the acceleration depends on the velocity (the Coriolis term −2ω×ṙ), so the method must be one of the
*general* RKN methods, which evaluate f at stage velocities (integrators/README.md "Methods the field compares
that are not here (yet)" says which published RKN methods do not apply). With c = (0, ½, ½, 1):

    k₁ = f(r, ṙ)
    k₂ = f(r + ½hṙ + ⅛h²k₁, ṙ + ½hk₁)
    k₃ = f(r + ½hṙ + ⅛h²k₁, ṙ + ½hk₂)
    k₄ = f(r + hṙ + ½h²k₃, ṙ + hk₃)
    r₁ = r + hṙ + h²(k₁ + k₂ + k₃)/6,   ṙ₁ = ṙ + h(k₁ + 2k₂ + 2k₃ + k₄)/6.

The loop adds the step as an increment with compensated summation (``integrators.fixed_step``), as for the
tableau methods. Order 4, 4 evaluations per step. On the undamped oscillator the one-step matrix has spectral radius ≤ 1 up to
kh ≈ 2.5865 (computed from the coefficients, tests/test_new_methods.py), below RK4's 2√2; not symplectic.
"""

from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator, state_plus
from foucault_bench.integrators.registry import register
from foucault_bench.models import Model
from foucault_bench.models.jit import jit

OSCILLATOR_STABILITY_LIMIT_KH = 2.5865
"""The first kh at which the spectral radius of the one-step matrix on ẍ = −k²x exceeds 1 (2.58652, rounded down)."""


@register
class Nystrom4(FixedStepIntegrator):
    name: ClassVar[str] = "nystrom4"
    family: ClassVar[str] = "runge-kutta-nystrom"
    order: ClassVar[int] = 4
    stages: ClassVar[int] = 4
    stability_limit_kh: ClassVar[float] = OSCILLATOR_STABILITY_LIMIT_KH
    reference: ClassVar[str] = (
        "Nyström, Acta Soc. Sci. Fenn. 50, No. 13 (1925); Hairer, Nørsett & Wanner, Solving ODEs I, §II.14"
    )

    def make_step(self, model: Model) -> Callable:
        return state_plus(self.make_increment(model))

    def make_increment(self, model: Model) -> Callable:
        """The step as an increment (dr, dṙ), which the fixed-step loop adds with compensated summation
        (``integrators.fixed_step``)."""
        acceleration = model.numba_acceleration

        @jit
        def increment(x, y, vx, vy, h, p):
            half = 0.5 * h
            eighth_h2 = 0.125 * h * h
            k1x, k1y = acceleration(x, y, vx, vy, p)
            x2 = x + half * vx + eighth_h2 * k1x
            y2 = y + half * vy + eighth_h2 * k1y
            k2x, k2y = acceleration(x2, y2, vx + half * k1x, vy + half * k1y, p)
            k3x, k3y = acceleration(x2, y2, vx + half * k2x, vy + half * k2y, p)
            half_h2 = 0.5 * h * h
            k4x, k4y = acceleration(x + h * vx + half_h2 * k3x, y + h * vy + half_h2 * k3y,
                                    vx + h * k3x, vy + h * k3y, p)
            sixth_h2 = h * h / 6.0
            sixth = h / 6.0
            return (
                h * vx + sixth_h2 * (k1x + k2x + k3x),
                h * vy + sixth_h2 * (k1y + k2y + k3y),
                sixth * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
                sixth * (k1y + 2.0 * k2y + 2.0 * k3y + k4y),
            )

        return increment
