"""``gbs``: Gragg-Bulirsch-Stoer extrapolation with order and step-size control (ODEX), compiled.

The explicit midpoint rule with Gragg's smoothing step over the harmonic sequence 2, 4, 6, …, extrapolated by
Aitken-Neville, with Hairer and Wanner's order and step-size control (Hairer, Nørsett & Wanner, Solving ODEs I,
2nd ed., §II.9; their code ODEX; Deuflhard, Numer. Math. 41, 399 (1983) for the work-per-step order choice):
``integrators.extrapolation_driver``. Variable order 4-18 (line j of the table has order 2j; the target line k
runs from 2 to 8, and a step is accepted in line k − 1, k or k + 1), chosen per step to minimise the
evaluations per unit step.

Tolerance mapping: rtol = tol and atol = tol × (R, R, kR, kR) (``integrators.adaptive``), ODEX's mixed
componentwise error test.

Output grid: the steps land on every output time (ODEX's dense output needs another sequence; integrators/README.md
"Gragg-Bulirsch-Stoer extrapolation"). No turning points are streamed (the verdicts take them from the grid).

Stability: explicit; the step control keeps the steps accuracy-limited at every tolerance used here.
"""

from __future__ import annotations

from typing import Callable, ClassVar

from foucault_bench.integrators.extrapolation_driver import compiled_driver
from foucault_bench.integrators.grid_stepping import GridSteppingIntegrator
from foucault_bench.integrators.registry import register
from foucault_bench.models import Model


@register
class Gbs(GridSteppingIntegrator):
    """ODEX's extrapolation code on the model's compiled acceleration (options: ``GridSteppingIntegrator``)."""

    name: ClassVar[str] = "gbs"
    family: ClassVar[str] = "extrapolation"
    order: ClassVar[int | None] = None
    reference: ClassVar[str] = ("Hairer, Nørsett & Wanner, Solving ODEs I, §II.9 (ODEX); Gragg, SIAM J. Numer. Anal. 2, "
                                "384 (1965); Bulirsch & Stoer, Numer. Math. 8, 1 (1966); Deuflhard, Numer. Math. 41, "
                                "399 (1983)")

    def compiled_driver(self, model: Model) -> Callable:
        return compiled_driver(model)
