"""Tenth-order composition of the rotating-frame Verlet step: Sofroniou and Spaletta's 35-stage method.

Φ_h = V_{γ₃₅h} ∘ … ∘ V_{γ₁h} with the symmetric weights below, V the rotating-frame Verlet step
(``integrators.methods.verlet``): symplectic, symmetric, order 10, 35 Verlet steps (70 force evaluations) per
step (Sofroniou & Spaletta, Optim. Methods Softw. 20, 597 (2005), s35odr10; digits as in SUNDIALS ARKODE's
table ``ARKODE_SPRK_SOFRONIOU_10_36`` and OrdinaryDiffEq.jl's ``SofSpa10``; the order conditions: Hairer, Lubich
& Wanner, Geometric Numerical Integration, 2nd ed., §V.3.2). ``Composition`` checks every order condition up
to 10 when the module is imported (residuals at most 2.5e-16; the largest one of order 11 is only 1.4e-6, the
reason the errors of this method reach round-off after few halvings of the step). Stability limit on the
oscillator: ``Composition.oscillator_stability_limit`` (≈ 5.974). Taken as sequences of at most
``SEQUENCE_SUB_STEPS`` sub-steps in the canonical variables (``integrators.composition``), one compiled sub-step
body in a loop (``integrators.methods.verlet.verlet_sequences``).
"""

from typing import ClassVar

from foucault_bench.integrators.composition import Composition, VerletComposition
from foucault_bench.integrators.registry import register

_HALF = (
    0.078795722521686419263907679337684,
    0.31309610341510852776481247192647,
    0.027918383235078066109520273275299,
    -0.22959284159390709415121339679655,
    0.13096206107716486317465685927961,
    -0.26973340565451071434460973222411,
    0.074973343155891435666137105641410,
    0.11199342399981020488957508073640,
    0.36613344954622675119314812353150,
    -0.39910563013603589787862981058340,
    0.10308739852747107731580277001372,
    0.41143087395589023782070411897608,
    -0.0048663605831352617621956593099771,
    -0.39203335370863990644808193642610,
    0.051942502962449647037182904015976,
    0.050665090759924496335874344156866,
    0.049674370639729879054568800279461,
)
SOFRONIOU_SPALETTA_S35ODR10 = Composition(weights=(*_HALF, 0.049317735759594537917680008339338, *reversed(_HALF)),
                                          order=10)


@register
class Composition10(VerletComposition):
    name: ClassVar[str] = "composition10"
    composition: ClassVar[Composition] = SOFRONIOU_SPALETTA_S35ODR10
    remainder_sweeps: ClassVar[int] = 10
    reference: ClassVar[str] = (
        "Sofroniou & Spaletta, Optim. Methods Softw. 20, 597 (2005), s35odr10; Hairer, Lubich & Wanner, "
        "Geometric Numerical Integration, 2nd ed., §V.3.2"
    )
