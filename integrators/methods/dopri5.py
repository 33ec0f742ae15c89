"""``dopri5``: the Dormand-Prince 5(4) pair (scipy's ``RK45``), compiled (``integrators.embedded_rk``).

Order 5 with 6 stages per step attempt (the 7th, f(t + h, y_new), is the next step's first: first same as
last), error estimated against the embedded 4th-order solution, controller exponent −1/5; quartic dense output
(Shampine, Math. Comp. 46, 135 (1986), scipy's ``RK45.P``). Coefficients: Dormand & Prince, J. Comput. Appl.
Math. 6, 19 (1980), Table 2, as in scipy's ``RK45``.

Tolerance mapping: rtol = tol, atol = tol × (R, R, kR, kR) (``integrators.adaptive``), as for ``scipy_rk45``,
whose run this integrator reproduces in compiled code: same steps and nfev, same output states and turning
points bit for bit where numpy sums on OpenBLAS (``integrators.embedded_rk``).

Stability: explicit, bounded stability region. On the undamped oscillator (eigenvalues ±ik) the amplification
|R(ikh)| with R(z) = 1 + z bᵀ(I − zA)⁻¹𝟙 (Hairer & Wanner, Solving ODEs II, §IV.2) stays ≤ 1 up to kh ≈ 1.0 and
exceeds 1 beyond (1.4e-6 at kh = 1, 3e-3 at 1.5); the error control keeps that growth below the tolerance, so
the steps are accuracy-limited at every tolerance used here.
"""

from __future__ import annotations

from typing import ClassVar

from scipy.integrate import RK45, OdeSolver

from foucault_bench.integrators.embedded_rk import EmbeddedRungeKutta
from foucault_bench.integrators.registry import register
from foucault_bench.integrators.tableau import ButcherTableau

TABLEAU = ButcherTableau(
    name="dopri5",
    c=(0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0),
    a=(
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        (1 / 5, 0.0, 0.0, 0.0, 0.0, 0.0),
        (3 / 40, 9 / 40, 0.0, 0.0, 0.0, 0.0),
        (44 / 45, -56 / 15, 32 / 9, 0.0, 0.0, 0.0),
        (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0, 0.0),
        (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0.0),
    ),
    b=(35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84),
    order=5,
    error_weights=(-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40),
    error_order=4,
    dense_weights=(
        (1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432),
        (0.0, 0.0, 0.0, 0.0),
        (0.0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799),
        (0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072),
        (0.0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632),
        (0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844),
        (0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423),
    ),
    dense_order=4,
    reference="Dormand & Prince, J. Comput. Appl. Math. 6, 19 (1980); Shampine, Math. Comp. 46, 135 (1986)",
)


@register
class Dopri5(EmbeddedRungeKutta):
    """Dormand-Prince 5(4) with scipy's error norm, controller and initial step, compiled: the steps of
    ``scipy_rk45``."""

    name: ClassVar[str] = "dopri5"
    tableau: ClassVar[ButcherTableau] = TABLEAU
    steps_of: ClassVar[type[OdeSolver] | None] = RK45
    reference: ClassVar[str] = TABLEAU.reference
