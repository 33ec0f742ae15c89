"""``fine_rkn5``: Fine's embedded general Runge-Kutta-Nyström pair of order 5, adaptive (``integrators.rkn``).

A general RKN pair for r̈ = f(t, r, ṙ), so it applies with the velocity-dependent Coriolis force, drag and drive
(integrators/README.md "Runge-Kutta-Nyström methods for a velocity-dependent force"): 7 stages, the last one
f(r₁, ṙ₁) reused as the next step's first (6 evaluations per attempt), order 5 with an embedded estimate of
order 4 for position and velocity (Fine, "Low order practical Runge-Kutta-Nyström methods", Computing 38, 281
(1987)). Coefficients: OrdinaryDiffEq.jl's ``FineRKN5`` tableau (lib/OrdinaryDiffEqRKN, ``FineRKN5Tableau``),
which gives Fine's method as exact fractions; the row sums and the first weight conditions are checked when the
pair is built, the local orders measured by tests/test_rkn.py, and the main method's order by ``selftest``,
stepped in 34 digits at fixed steps (``bench.gate.multiprecision_order``: 5.007-5.010 on the linear and damped
models, measured 2026-12-04).

Tolerance mapping: rtol = tol and atol = tol × (R, R, kR, kR) (``integrators.adaptive``). The steps land on
every output time (``integrators.rkn``); no turning points are streamed (the verdicts take them from the grid).

Stability: explicit; the step control keeps the steps accuracy-limited at every tolerance used here.
"""

from __future__ import annotations

from fractions import Fraction as F
from typing import Callable, ClassVar

from foucault_bench.integrators.grid_stepping import GridSteppingIntegrator
from foucault_bench.integrators.registry import register
from foucault_bench.integrators.rkn import NystromPair, compiled_driver
from foucault_bench.models import Model


def _rows(entries: dict[int, dict[int, F]], size: int) -> tuple[tuple[F, ...], ...]:
    return tuple(tuple(entries.get(i, {}).get(j, F(0)) for j in range(size)) for i in range(size))


POSITION = {  # ā (of h²), 0-indexed stages
    1: {0: F(32, 1521)}, 2: {0: F(4, 169), 1: F(4, 169)}, 3: {0: F(175, 5184), 2: F(1625, 5184)},
    4: {0: F(-342497279, 5618900760), 1: F(6827067, 46824173), 2: F(35048741, 102161832),
        3: F(-2201514, 234120865)},
    5: {0: F(-7079, 52152), 1: F(767, 2173), 2: F(14027, 52152), 3: F(30, 2173)},
    6: {0: F(4817, 51600), 2: F(388869, 1216880), 3: F(3276, 23575), 4: F(-1142053, 22015140)},
}
VELOCITY = {  # a (of h)
    1: {0: F(8, 39)}, 2: {0: F(1, 13), 1: F(3, 13)},
    3: {0: F(7385, 6912), 1: F(-9425, 2304), 2: F(13325, 3456)},
    4: {0: F(223324757, 91364240), 1: F(-174255393, 18272848), 2: F(382840094, 46824173),
        3: F(-39627252, 234120865)},
    5: {0: F(108475, 36464), 1: F(-9633, 848), 2: F(7624604, 806183), 3: F(8100, 49979), 4: F(-4568212, 19446707)},
    6: {0: F(4817, 51600), 2: F(1685099, 3650640), 3: F(19656, 23575), 4: F(-53676491, 88060560), 5: F(53, 240)},
}

PAIR = NystromPair(
    name="fine_rkn5",
    c=(F(0), F(8, 39), F(4, 13), F(5, 6), F(43, 47), F(1), F(1)),
    position=_rows(POSITION, 7),
    velocity=_rows(VELOCITY, 7),
    position_weights=_rows(POSITION, 7)[6],
    velocity_weights=_rows(VELOCITY, 7)[6],
    position_error=(F(8151, 2633750), F(0), F(-1377519, 186334750), F(586872, 28879375),
                    F(-36011118, 2247378875), F(0), F(0)),
    velocity_error=(F(8151, 2633750), F(0), F(-5969249, 559004250), F(3521232, 28879375),
                    F(-846261273, 4494757750), F(4187, 36750), F(-1, 25)),
    order=5,
    error_order=4,
)


@register
class FineRkn5(GridSteppingIntegrator):
    """Fine's RKN 5(4) pair on the model's compiled acceleration (options: ``GridSteppingIntegrator``)."""

    name: ClassVar[str] = "fine_rkn5"
    family: ClassVar[str] = "runge-kutta-nystrom"
    order: ClassVar[int | None] = PAIR.order
    reference: ClassVar[str] = "Fine, Computing 38, 281 (1987); Hairer, Nørsett & Wanner, Solving ODEs I, §II.14"
    pair: ClassVar[NystromPair] = PAIR
    """The coefficients, exact: ``foucault-bench selftest`` measures the main method's order from them in 34
    digits (``bench.gate.multiprecision_order``)."""

    def compiled_driver(self, model: Model) -> Callable:
        return compiled_driver(model, self.pair)
