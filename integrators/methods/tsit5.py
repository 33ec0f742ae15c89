"""``tsit5``: Tsitouras' 5(4) pair, compiled (``integrators.embedded_rk``).

Order 5 with 6 stages per step attempt (the 7th, f(t + h, y_new), is the next step's first: first same as
last), error estimated against the embedded 4th-order solution, controller exponent −1/5, quartic dense output.
Tsitouras chose the coefficients without the simplifying assumption b̂₇ = 0 that Dormand and Prince used, for
smaller principal error coefficients (Tsitouras, Comput. Math. Appl. 62, 770 (2011)); the coefficients
(Table 1 of the paper, with its dense output) are those of DifferentialEquations.jl's ``Tsit5`` and diffrax's
``Tsit5``. The step-size control is the suite's (scipy's, ``integrators.embedded_rk``), so the pair can be
compared with ``dopri5`` at identical control.

Tolerance mapping: rtol = tol, atol = tol × (R, R, kR, kR) (``integrators.adaptive``).

Stability: explicit, bounded stability region. On the undamped oscillator the amplification |R(ikh)|, R(z) =
1 + z bᵀ(I − zA)⁻¹𝟙 (Hairer & Wanner, Solving ODEs II, §IV.2), stays ≤ 1 only up to kh ≈ 0.48 and exceeds 1
slightly beyond (6e-8 at kh = 0.5, 1.3e-4 at 1); the error control keeps that growth below the tolerance, so
the steps are accuracy-limited at every tolerance used here.
"""

from __future__ import annotations

from typing import ClassVar

from foucault_bench.integrators.embedded_rk import EmbeddedRungeKutta
from foucault_bench.integrators.registry import register
from foucault_bench.integrators.tableau import ButcherTableau

TABLEAU = ButcherTableau(
    name="tsit5",
    c=(0.0, 0.161, 0.327, 0.9, 0.9800255409045097, 1.0),
    a=(
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        (0.161, 0.0, 0.0, 0.0, 0.0, 0.0),
        (-0.008480655492356989, 0.335480655492357, 0.0, 0.0, 0.0, 0.0),
        (2.8971530571054935, -6.359448489975075, 4.3622954328695815, 0.0, 0.0, 0.0),
        (5.325864828439257, -11.748883564062828, 7.4955393428898365, -0.09249506636175525, 0.0, 0.0),
        (5.86145544294642, -12.92096931784711, 8.159367898576159, -0.071584973281401, -0.028269050394068383, 0.0),
    ),
    b=(0.09646076681806523, 0.01, 0.4798896504144996, 1.379008574103742, -3.290069515436081, 2.324710524099774),
    order=5,
    error_weights=(-0.00178001105222577714, -0.0008164344596567469, 0.007880878010261995, -0.1447110071732629,
                   0.5823571654525552, -0.45808210592918697, 1 / 66),
    error_order=4,
    dense_weights=(
        (1.0, -2.763706197274826, 2.9132554618219126, -1.0530884977290216),
        (0.0, 0.13169999999999998, -0.2234, 0.1017),
        (0.0, 3.9302962368947516, -5.941033872131505, 2.490627285651253),
        (0.0, -12.411077166933676, 30.33818863028232, -16.548102889244902),
        (0.0, 37.50931341651104, -88.1789048947664, 47.37952196281928),
        (0.0, -27.896526289197286, 65.09189467479366, -34.87065786149661),
        (0.0, 1.5, -4.0, 2.5),
    ),
    dense_order=4,
    reference="Tsitouras, Comput. Math. Appl. 62, 770 (2011)",
)


@register
class Tsit5(EmbeddedRungeKutta):
    """Tsitouras 5(4) with scipy's error norm, controller and initial step, compiled."""

    name: ClassVar[str] = "tsit5"
    main_method_unmeasurable: ClassVar[str] = (
        "Tsitouras minimised the leading error coefficients and published the coefficients to 16 digits: in double "
        "the next error term dominates down to round-off (order fit 5.2-5.3 on the linear model), and stepped in "
        "34 digits with those digits the error stops falling at 1.2-1.5e-15 (fit 5.08-5.10): see Verner's pairs in "
        "integrators/README.md"
    )
    tableau: ClassVar[ButcherTableau] = TABLEAU
    reference: ClassVar[str] = TABLEAU.reference
