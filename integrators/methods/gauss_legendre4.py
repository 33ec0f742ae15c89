"""Two-stage Gauss–Legendre method (order 4): the collocation method at the Gauss points ½ ∓ √3/6.

Order 4, symmetric, symplectic, A-stable, conserves quadratic invariants exactly (the linear model's energy to
round-off). Solved by fixed-point iteration to round-off (``integrators.gauss``: solve limit kh < 2√3).
Butcher, Math. Comp. 18, 50 (1964); Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed.,
§II.1.3 and Table II.1.1; Hairer & Wanner, Solving ODEs II, §IV.5.
"""

import math
from typing import ClassVar

from foucault_bench.integrators.gauss import GaussCollocation
from foucault_bench.integrators.registry import register


@register
class GaussLegendre4(GaussCollocation):
    name: ClassVar[str] = "gauss_legendre4"
    order: ClassVar[int] = 4
    collocation_stages: ClassVar[int] = 2
    stability_limit_kh: ClassVar[float] = 2.0 * math.sqrt(3.0)
    reference: ClassVar[str] = (
        "Butcher, Math. Comp. 18, 50 (1964); Hairer, Lubich & Wanner, Geometric Numerical Integration, "
        "2nd ed., §II.1.3, §VIII.6"
    )
