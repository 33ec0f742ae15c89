"""Yoshida's fourth-order triple jump of the rotating-frame Verlet step.

Φ_h = V_{γ₁h} ∘ V_{γ₂h} ∘ V_{γ₁h} with γ₁ = 1/(2 − 2^{1/3}) ≈ 1.3512, γ₂ = 1 − 2γ₁ ≈ −1.7024, V the
rotating-frame Verlet step (``integrators.methods.verlet``): symplectic, symmetric, order 4, 3 Verlet steps (6 force
evaluations) per step. The negative middle sub-step makes the error constant large (Yoshida, Phys. Lett. A
150, 262 (1990), eq. (4.14); Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §II.4, eq.
(4.4)). Stability limit on the oscillator: ``Composition.oscillator_stability_limit`` (≈ 1.573).
"""

from typing import ClassVar

from foucault_bench.integrators.composition import Composition, VerletComposition, triple_jump
from foucault_bench.integrators.registry import register


@register
class Yoshida4(VerletComposition):
    name: ClassVar[str] = "yoshida4"
    composition: ClassVar[Composition] = triple_jump(4)
    reference: ClassVar[str] = (
        "Yoshida, Phys. Lett. A 150, 262 (1990); Hairer, Lubich & Wanner, Geometric Numerical Integration, "
        "2nd ed., §II.4"
    )
