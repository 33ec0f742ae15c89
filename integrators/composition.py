"""Composition methods: a symmetric second-order step Φ_h composed as Φ_{γ_s h} ∘ … ∘ Φ_{γ_1 h}.

A composition is data: the weights γ_1 … γ_s (``Composition``), checked when it is built. For a symmetric base
method of order 2 and symmetric weights (γ_i = γ_{s+1−i}) the composition is symmetric, so only even orders
occur, and it has order

* 2 when Σ γ_i = 1 (consistency),
* 4 when moreover Σ γ_i³ = 0,
* 6 when moreover Σ γ_i⁵ = 0 and one more condition holds that couples the weights (it is not a power sum;
  Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §V.3.2, eq. (3.8) and Table V.3.1),
* 8 and 10 when moreover Σ γ_i⁷ = 0 (and Σ γ_i⁹ = 0 for 10) and further coupled conditions hold (4 more for
  order 8, 11 more for order 10; HLW Table V.3.1).

``Composition`` checks symmetry and every order condition up to the declared order, power sums and coupled
conditions alike (``order_condition_residuals``): a symmetric second-order method has a modified vector field
h Y₁ + h³ Y₃ + h⁵ Y₅ + … (odd powers only; HLW §II.3, §IX.1), so Φ_{γh} = exp(γh Y₁ + (γh)³ Y₃ + …) and the
composition is exp(log Π_i exp(Σ_k (γ_i h)^k Y_k)). Computed in the free associative algebra of the
non-commuting Y₁, Y₃, … (words weighted by their h-power) and truncated above h^(p+1), that logarithm equals
h Y₁ for every base method exactly when the composition has order p: every word of weight 2 … p must have
coefficient 0 (the single-letter words give Σγᵏ; the others are the coupled conditions of HLW §V.3.2, from
the Baker-Campbell-Hausdorff formula, HLW §III.4). The observed order of every composition is measured by the
test suite like any other integrator's. The composition of
symplectic maps is symplectic, so a composition of the rotating-frame Verlet step (``integrators.methods.verlet``) is
symplectic, symmetric and of the declared order (Yoshida, Phys. Lett. A 150, 262 (1990); Suzuki, Phys. Lett.
A 146, 319 (1990)).

On the undamped oscillator each Verlet sub-step with step γh is the 2×2 map M(γkh) with trace 2 − (γkh)²; the
composition is stable while |trace Π M(γ_i kh)| < 2. ``oscillator_stability_limit`` finds the first kh where
that fails, which is the limit each composition declares.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.fixed_step import with_setup
from foucault_bench.integrators.methods.verlet import RotatingVerlet, verlet_sequences
from foucault_bench.models import Model

SEQUENCE_SUB_STEPS = 9
"""Sub-steps per sequence in the canonical variables (``verlet_sequences``): a longer composition returns to
(x, y, vx, vy) after every 9 sub-steps, which is the same map to round-off (one extra change of variables and
one split rotation per sequence). Kept so that ``composition8`` and ``composition10`` give bitwise the results
of the earlier code, which had to compile its sequences unrolled (35 sub-steps in one did not compile within 4
minutes); the loop over the sub-steps compiles any length in the time of one."""

POWER_SUM_TOLERANCE = 1e-14
"""How far from zero an order condition (and from one Σγ) may be, per stage and times max(1, max|γ|) to the
condition's weight: a few ulp of the largest term (measured on the built-in weights: at most 2.5e-16 for the
15- and 35-stage compositions, whose every |γ| < 1)."""


@dataclass(frozen=True)
class Composition:
    """Symmetric weights γ_1 … γ_s of a composition of a symmetric second-order step, and its order.

    Raises ``ValueError`` at construction when the weights are not symmetric, do not sum to one, or violate an
    order condition the declared order needs (``order_condition_residuals``: Σγ³ = 0 for order ≥ 4, Σγ⁵ = 0
    and one coupled condition for order ≥ 6, …).
    """

    weights: tuple[float, ...]
    order: int

    def __post_init__(self) -> None:
        gamma = np.asarray(self.weights, dtype=np.float64)
        scale = float(np.max(np.abs(gamma)))
        if self.order not in (2, 4, 6, 8, 10):
            raise ValueError(f"order must be 2, 4, 6, 8 or 10, got {self.order}")
        if not np.array_equal(gamma, gamma[::-1]):
            raise ValueError("weights must be symmetric (γ_i = γ_(s+1-i))")
        if abs(gamma.sum() - 1.0) > POWER_SUM_TOLERANCE * gamma.size:
            raise ValueError(f"weights must sum to 1, sum to {gamma.sum()!r}")
        for word, residual in order_condition_residuals(self.weights, self.order).items():
            if abs(residual) > POWER_SUM_TOLERANCE * gamma.size * max(1.0, scale) ** sum(word):
                condition = f"Σγ^{word[0]} = 0" if len(word) == 1 else f"the coupled condition of Y{word}"
                raise ValueError(f"order {self.order} needs {condition}, got {residual:.3e}")

    @property
    def stages(self) -> int:
        return len(self.weights)

    def oscillator_stability_limit(self, *, kh_max: float = 10.0, resolution: float = 1e-10) -> float:
        """The smallest kh at which the composition of Verlet steps becomes unstable on ẍ = −k²x (first kh
        with |trace| ≥ 2 of the product of the sub-steps' matrices), by a scan then bisection."""

        def half_trace(kh: np.ndarray) -> np.ndarray:
            """½ trace of the product at every kh of the array ``kh`` at once (the 2×2 products elementwise)."""
            p11, p12, p21, p22 = np.ones_like(kh), np.zeros_like(kh), np.zeros_like(kh), np.ones_like(kh)
            for gamma in self.weights:
                s = gamma * kh  # Verlet on (x, v/k): kick, drift, kick with step s
                m11, m12, m21 = 1.0 - 0.5 * s * s, s, -s * (1.0 - 0.25 * s * s)
                p11, p12, p21, p22 = (m11 * p11 + m12 * p21, m11 * p12 + m12 * p22,
                                      m21 * p11 + m11 * p21, m21 * p12 + m11 * p22)
            return 0.5 * (p11 + p22)

        grid = np.arange(1, int(kh_max / 1e-3) + 1) * 1e-3
        unstable = float(grid[np.argmax(np.abs(half_trace(grid)) >= 1.0)])
        low, high = unstable - 1e-3, unstable
        while high - low > resolution:
            middle = 0.5 * (low + high)
            low, high = (low, middle) if abs(half_trace(np.array([middle]))[0]) >= 1.0 else (middle, high)
        return low


class VerletComposition(FixedStepIntegrator):
    """Base of the compositions of the rotating-frame Verlet step: a subclass declares ``composition``."""

    family: ClassVar[str] = "symplectic-composition"
    symplectic: ClassVar[bool] = True
    composition: ClassVar[Composition]
    remainder_sweeps: ClassVar[int] = 2
    """Fixed-point sweeps of the Verlet step's implicit half kick on a model with a velocity-dependent remainder
    (``verlet_sequences``): the composition has its order only if its base step is symmetric to beyond it."""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "composition" in cls.__dict__:
            cls.order = cls.composition.order
            cls.stages = RotatingVerlet.stages * cls.composition.stages
            cls.stability_limit_kh = cls.composition.oscillator_stability_limit()

    def make_step(self, model: Model) -> Callable:
        return with_setup(*self.make_setup_step(model))

    def make_setup_step(self, model: Model) -> tuple[Callable, Callable]:
        return verlet_sequences(model, self.composition.weights, SEQUENCE_SUB_STEPS, self.remainder_sweeps)


Word = tuple[int, ...]
"""A product Y_(k₁) Y_(k₂) … of the base method's odd-order terms, as the tuple of its orders (its weight: their sum)."""


def order_condition_residuals(weights: tuple[float, ...], order: int) -> dict[Word, float]:
    """The coefficient of every word of weight 2 … ``order`` in log Π_i exp(Σ_k (γ_i h)^k Y_k) (module docstring):
    all zero exactly when the composition with ``weights`` has order ``order`` for every symmetric base method
    of order 2. Series are dicts word → coefficient, truncated above weight ``order``."""
    letters = range(1, order + 1, 2)
    product: dict[Word, float] = {(): 1.0}
    for gamma in weights:
        product = _times(product, _exp({(k,): gamma**k for k in letters}, order), order)
    logarithm = _log(product, order)
    return {word: logarithm.get(word, 0.0) for word in _words(order) if sum(word) >= 2}


def _words(max_weight: int, letters: tuple[int, ...] = ()) -> list[Word]:
    """Every word in the odd letters 1, 3, 5, … of weight at most ``max_weight``."""
    return [letters] + [word for k in range(1, max_weight + 1, 2) for word in _words(max_weight - k, letters + (k,))]


def _times(a: dict[Word, float], b: dict[Word, float], max_weight: int) -> dict[Word, float]:
    product: dict[Word, float] = {}
    right = [(word, coefficient, sum(word)) for word, coefficient in b.items()]
    for word_a, coefficient_a in a.items():
        room = max_weight - sum(word_a)
        for word_b, coefficient_b, weight_b in right:
            if weight_b <= room:
                product[word_a + word_b] = product.get(word_a + word_b, 0.0) + coefficient_a * coefficient_b
    return product


def _exp(x: dict[Word, float], max_weight: int) -> dict[Word, float]:
    """exp(x) = Σ xⁿ/n! for a series without a constant term (xⁿ has weight ≥ n)."""
    result: dict[Word, float] = {(): 1.0}
    term: dict[Word, float] = {(): 1.0}
    for n in range(1, max_weight + 1):
        term = {word: c / n for word, c in _times(term, x, max_weight).items()}
        result = {word: result.get(word, 0.0) + term.get(word, 0.0) for word in result.keys() | term.keys()}
    return result


def _log(y: dict[Word, float], max_weight: int) -> dict[Word, float]:
    """log(y) = Σ (−1)ⁿ⁺¹ xⁿ/n with x = y − 1 (y's constant term is 1)."""
    x = {word: c for word, c in y.items() if word}
    result: dict[Word, float] = {}
    power: dict[Word, float] = {(): 1.0}
    for n in range(1, max_weight + 1):
        power = _times(power, x, max_weight)
        for word, c in power.items():
            result[word] = result.get(word, 0.0) + (-1) ** (n + 1) * c / n
    return result


def triple_jump(order: int) -> Composition:
    """Yoshida's triple jump raising a symmetric method of order ``order`` − 2 to ``order``:
    γ_1 = γ_3 = 1/(2 − 2^{1/(order−1)}), γ_2 = 1 − 2γ_1 (Yoshida 1990, eq. (4.14); HLW eq. (V.3.5))."""
    root = 2.0 ** (1.0 / (order - 1))
    outer = 1.0 / (2.0 - root)
    return Composition(weights=(outer, 1.0 - 2.0 * outer, outer), order=order)

