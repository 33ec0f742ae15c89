"""Butcher tableaux of explicit Runge-Kutta methods as self-validating data (``ButcherTableau``).

A tableau is a plain method (``c``, ``a``, ``b``: explicit Euler, RK4, Heun's third-order method, stepped by
``integrators.explicit_rk``) or, with its optional error weights and dense output, an embedded pair (stepped by
``integrators.embedded_rk``).

A tableau is checked when it is built, so a mistyped coefficient cannot reach an integration:

* shapes, finite entries, c₁ = 0, an explicit method (``a`` strictly lower triangular);
* row sums Σⱼ aᵢⱼ = cᵢ (Hairer, Nørsett & Wanner, Solving ODEs I, §II.1, eq. (1.9));
* the order conditions of the main weights ``b`` up to ``order``, of each embedded solution b − e up to its
  declared order, and of the dense output up to ``dense_order`` (the last two where given): for every rooted tree t with ρ(t) ≤ p,
  Σᵢ bᵢ Φᵢ(t) = 1/γ(t) (HNW I, §II.2, Theorem 2.13; the trees are generated here, 719 of them up to order 9),
  and for a continuous extension with weights bᵢ(θ), Σᵢ bᵢ(θ) Φᵢ(t) = θ^ρ(t)/γ(t) (HNW I, §II.6, Theorem 6.1),
  checked coefficient by coefficient of the polynomials in θ.

Layout (scipy's ``RungeKutta`` convention, ``scipy/integrate/_ivp/rk.py``): stages 1…s are given by ``c``, ``a``
and ``b``; stage s + 1 is f(t + h, y_new), the first stage of the next step ("first same as last", FSAL), so the
error weights ``e`` have s + 1 entries and the embedded solution is (b, 0) − e. Dense output may add stages
s + 2, … (``dense_c``, ``dense_a``, rows over every earlier stage, e.g. DOP853's three extra stages), and gives
the weights bᵢ(θ) = Σₖ Pᵢₖ θ^(k+1) of y(t + θh) = y + h Σᵢ bᵢ(θ) kᵢ over all of these stages, either directly
(``dense_weights``, scipy's ``RkDenseOutput``) or in Hairer's form (``dense_hairer``, DOP853's ``CONTD8``), from
which the weights are derived for the checks.

Round-off: the coefficients are doubles, so a condition holds to a few units of round-off of the sum of the
absolute values of its terms, not exactly; ``CONDITION_RTOL`` bounds the residual relative to that sum. A tableau
built from its published digits (``from_stage_data``) also keeps its main method's c, A and b as exact rationals
(``ExactCoefficients``), checked to round to the doubles, so that its order can be measured in more than double
precision (``bench.gate.multiprecision_order``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

CONDITION_RTOL = 1.0e-13
"""Largest |residual| / (sum of |terms|) accepted for a row sum, an order condition or the continuity of the
dense output. The shipped tableaux measure at most 8.4e-17 (below one unit of 2⁻⁵³): a margin of about 1000,
and a coefficient wrong in its seventh significant digit is rejected (tests/test_tableau.py)."""

MAX_CHECKED_ORDER = 9
"""Order conditions are generated up to this order (719 rooted trees); Vern9 and its interpolant need 9."""

Tree = tuple  # a rooted tree: the sorted tuple of its children's trees; the single node is ()


def _canonical(children) -> Tree:
    return tuple(sorted(children))


def _grown(tree: Tree):
    """Every tree obtained from ``tree`` by attaching one new leaf to one of its nodes."""
    yield _canonical(tree + ((),))
    for index, child in enumerate(tree):
        for bigger in _grown(child):
            yield _canonical(tree[:index] + (bigger,) + tree[index + 1:])


@functools.cache
def rooted_trees(order: int) -> tuple[Tree, ...]:
    """All rooted trees with ``order`` nodes (1, 1, 2, 4, 9, 20, 48, 115 for orders 1-8; HNW I, Table II.2.1)."""
    if order == 1:
        return ((),)
    return tuple(sorted({bigger for tree in rooted_trees(order - 1) for bigger in _grown(tree)}))


@functools.cache
def tree_order(tree: Tree) -> int:
    """ρ(t): the number of nodes."""
    return 1 + sum(tree_order(child) for child in tree)


@functools.cache
def tree_density(tree: Tree) -> int:
    """γ(t) = ρ(t) Π γ(children) (HNW I, Definition II.2.10)."""
    return tree_order(tree) * math.prod(tree_density(child) for child in tree)


@functools.cache
def rooted_trees_up_to(order: int) -> tuple[Tree, ...]:
    """Every rooted tree with at most ``order`` nodes, by order (719 up to order 9)."""
    return tuple(tree for rho in range(1, order + 1) for tree in rooted_trees(rho))


@functools.lru_cache(maxsize=64)
def _elementary_table(a_bytes: bytes, rows: int, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Φ, Φ over |A|, 1/γ) for every tree up to ``order``, Φ as a (trees × stages) matrix. The elementary
    weights Φᵢ(t) are 1 for the single node and Πₖ (A Φ(tₖ))ᵢ over the children tₖ (HNW I, Definition II.2.9);
    with |A| they give the sum of the absolute values of the terms (the round-off scale of a condition). Each
    tree's weights are built once from its children's (which precede it), so that every weight vector of one
    tableau is checked by one matrix product."""
    a = np.frombuffer(a_bytes).reshape(rows, rows)
    trees = rooted_trees_up_to(order)
    index = {tree: position for position, tree in enumerate(trees)}
    phi, phi_abs = np.ones((len(trees), rows)), np.ones((len(trees), rows))
    for position, tree in enumerate(trees):
        for child in tree:
            phi[position] *= a @ phi[index[child]]
            phi_abs[position] *= np.abs(a) @ phi_abs[index[child]]
    return phi, phi_abs, np.array([1.0 / tree_density(tree) for tree in trees])


def order_condition_residuals(a: np.ndarray, weights: np.ndarray, order: int) -> list[tuple[Tree, float, float]]:
    """(tree, residual Σ wᵢΦᵢ(t) − 1/γ(t), round-off scale) for every tree up to ``order``."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    phi, phi_abs, inverse_density = _elementary_table(a.tobytes(), a.shape[0], order)
    residuals = phi @ weights - inverse_density
    scales = phi_abs @ np.abs(weights) + inverse_density
    return list(zip(rooted_trees_up_to(order), residuals.tolist(), scales.tolist(), strict=True))


def _vector(values, length: int, what: str) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.shape != (length,):
        raise ValueError(f"{what} must hold {length} numbers, got shape {array.shape}")
    return array


@dataclass(frozen=True)
class ExactCoefficients:
    """The nodes c, coefficients A (full s × s rows) and weights b of a main method as exact rationals: the
    published digits, not rounded to doubles, for stepping the method in more than double precision."""

    c: tuple[Fraction, ...]
    a: tuple[tuple[Fraction, ...], ...]
    b: tuple[Fraction, ...]

    def rounding_problems(self, c: tuple[float, ...], a: tuple[tuple[float, ...], ...],
                          b: tuple[float, ...]) -> list[str]:
        """Where these values, rounded to the nearest double, differ from the tableau's ``c``, ``a`` and ``b``
        (one message per array; empty when every entry rounds to the double given)."""
        problems = []
        for what, exact_values, doubles in (("c", self.c, c), ("a", tuple(x for row in self.a for x in row),
                                                                 tuple(x for row in a for x in row)), ("b", self.b, b)):
            rounded = tuple(float(x) for x in exact_values)
            if rounded != tuple(float(x) for x in doubles):
                problems.append(f"exact coefficients: {what} does not round to the tableau's doubles")
        return problems


@dataclass(frozen=True)
class ButcherTableau:
    """An explicit Runge-Kutta method, optionally an embedded pair with dense output (see the module docstring for
    the layout and the checks).

    Attributes:
        name: short name used in messages.
        c, a, b: nodes (s), coefficients (s × s, strictly lower triangular), weights (s) of the main method.
        order: order of the main method (the b weights).
        reference: where the coefficients come from.
        error_weights: e (s + 1): the local error estimate is h Σᵢ eᵢ kᵢ; (b, 0) − e has order ``error_order``;
            ``None`` for a method without an error estimate (``is_embedded`` is then false).
        error_order: order of that embedded solution (``None`` exactly when ``error_weights`` is).
        exact: the main method's c, A and b as exact rationals (``ExactCoefficients``), where the published
            digits are known to more places than a double holds; ``None`` otherwise.
        secondary_error_weights, secondary_error_order: DOP853's second embedded solution (order 3) whose
            estimate enters its error norm (Hairer, Nørsett & Wanner I, §II.10); ``None`` otherwise. The order
            of the error estimate then follows (``error_estimator_order``).
        dense_c, dense_a: extra stages for the dense output (rows over all earlier stages, FSAL stage included).
        dense_weights: P, (s + 1 + extra stages) × degree: bᵢ(θ) = Σₖ Pᵢₖ θ^(k+1).
        dense_hairer: instead of P, the rows D of Hairer's form y_old + θ(F₀ + (1−θ)(F₁ + θ(F₂ + (1−θ)(F₃ + …))))
            with F₀ = Δy = y_new − y_old, F₁ = hk₁ − Δy, F₂ = 2Δy − h(k₁ + k_{s+1}) and F₃₊ᵣ = h Σⱼ Dᵣⱼ kⱼ over
            every stage (Hairer, Nørsett & Wanner I, §II.6; dop853.f, CONTD8).
        dense_order: order of the continuous extension (``None`` exactly when no dense output is given).
    """

    name: str
    c: tuple[float, ...]
    a: tuple[tuple[float, ...], ...]
    b: tuple[float, ...]
    order: int
    reference: str
    error_weights: tuple[float, ...] | None = None
    error_order: int | None = None
    dense_order: int | None = None
    dense_weights: tuple[tuple[float, ...], ...] = ()
    dense_hairer: tuple[tuple[float, ...], ...] | None = None
    dense_c: tuple[float, ...] = ()
    dense_a: tuple[tuple[float, ...], ...] = ()
    secondary_error_weights: tuple[float, ...] | None = None
    secondary_error_order: int | None = None
    exact: ExactCoefficients | None = field(default=None, compare=False, hash=False, repr=False)
    """Not hashed nor compared: a tableau is a cache key of its compiled driver, looked up on every solve, and
    hashing some 300 forty-digit fractions cost vern9 about 0.3 ms a solve."""

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ValueError(f"Butcher tableau {self.name!r} is invalid:\n  " + "\n  ".join(problems))

    # --- shapes -----------------------------------------------------------------------------------------------
    @property
    def stages(self) -> int:
        """s: right-hand-side evaluations per step (per step attempt of a pair, whose f(t + h, y_new) is the next
        step's first)."""
        return len(self.c)

    @property
    def is_embedded(self) -> bool:
        """Whether the tableau carries an error estimate (the adaptive driver needs one, and a dense output)."""
        return self.error_weights is not None

    @property
    def has_dense_output(self) -> bool:
        return self.dense_order is not None

    @property
    def error_estimator_order(self) -> int:
        """q such that the estimate behaves like h^(q+1): the controller's exponent is −1/(q + 1) (scipy's
        ``error_estimator_order``). One estimate of order p̂: q = p̂. DOP853's ‖err₅‖²/√(‖err₅‖² + 0.01‖err₃‖²)
        ~ ‖err₅‖²/‖err₃‖ = O(h^(2(p̂+1) − (p̃+1))) with p̂ = 5, p̃ = 3: q = 7."""
        if self.error_order is None:
            raise ValueError(f"tableau {self.name!r} has no error estimate")
        if self.secondary_error_order is None:
            return self.error_order
        return 2 * (self.error_order + 1) - (self.secondary_error_order + 1) - 1

    @property
    def extra_stages(self) -> int:
        return len(self.dense_c)

    def extended_a(self) -> np.ndarray:
        """A over every stage: the method's s, the FSAL stage (row b) and the dense-output stages."""
        s, extra = self.stages, self.extra_stages
        full = np.zeros((s + 1 + extra, s + 1 + extra))
        full[:s, :s] = np.asarray(self.a, dtype=np.float64).reshape(s, s)
        full[s, :s] = self.b
        if extra:
            full[s + 1:, :] = np.asarray(self.dense_a, dtype=np.float64).reshape(extra, s + 1 + extra)
        return full

    def extended_c(self) -> np.ndarray:
        return np.concatenate([np.asarray(self.c, dtype=np.float64), [1.0], np.asarray(self.dense_c, dtype=np.float64)])

    def extended_b(self) -> np.ndarray:
        """(b, 0, 0…): the main weights over every stage."""
        weights = np.zeros(self.stages + 1 + self.extra_stages)
        weights[: self.stages] = self.b
        return weights

    def dense_matrix(self) -> np.ndarray:
        """P: ``dense_weights``, or the expansion of ``dense_hairer`` into powers of θ."""
        if self.dense_hairer is None:
            return np.asarray(self.dense_weights, dtype=np.float64)
        s, rows = self.stages, self.stages + 1 + self.extra_stages
        combinations = [np.concatenate([self.b, np.zeros(rows - s)])]
        combinations.append(-combinations[0] + np.eye(rows)[0])
        combinations.append(2.0 * combinations[0] - np.eye(rows)[0] - np.eye(rows)[s])
        combinations += list(np.asarray(self.dense_hairer, dtype=np.float64).reshape(-1, rows))
        theta, one_minus = np.polynomial.Polynomial([0.0, 1.0]), np.polynomial.Polynomial([1.0, -1.0])
        multiplier = np.polynomial.Polynomial([1.0])
        weights = np.zeros((rows, len(combinations) + 1))
        for index, combination in enumerate(combinations):  # Fᵢ is multiplied by θ^⌈(i+1)/2⌉ (1 − θ)^⌊(i+1)/2⌋
            multiplier = multiplier * (theta if index % 2 == 0 else one_minus)
            weights[:, : multiplier.coef.size] += np.outer(combination, multiplier.coef)
        return weights[:, 1:]

    # --- validation -------------------------------------------------------------------------------------------
    def problems(self) -> list[str]:
        """Every violated requirement, one message each (empty: a valid tableau)."""
        s, extra = self.stages, self.extra_stages
        try:
            a = np.asarray(self.a, dtype=np.float64)
            b = _vector(self.b, s, "b")
            if (self.error_weights is None) != (self.error_order is None):
                raise ValueError("give error_weights and error_order together, or neither")
            if self.error_weights is None and self.secondary_error_weights is not None:
                raise ValueError("secondary_error_weights need error_weights")
            if self.error_weights is not None:
                _vector(self.error_weights, s + 1, "error_weights")
            if self.secondary_error_weights is not None:
                _vector(self.secondary_error_weights, s + 1, "secondary_error_weights")
            _vector(self.dense_c, extra, "dense_c")
            dense_a = np.asarray(self.dense_a, dtype=np.float64)
            if a.shape != (s, s):
                raise ValueError(f"a must be {s} × {s}, got shape {a.shape}")
            if extra and dense_a.shape != (extra, s + 1 + extra):
                raise ValueError(f"dense_a must be {extra} × {s + 1 + extra}, got shape {dense_a.shape}")
            given_dense = (self.dense_hairer is not None) + (len(self.dense_weights) != 0)
            if given_dense > 1 or (given_dense == 1) != (self.dense_order is not None):
                raise ValueError("give the dense output as dense_weights or as dense_hairer, with dense_order "
                                 "(or none of them)")
            if extra and self.dense_order is None:
                raise ValueError("dense_c and dense_a are stages of a dense output: give it")
            if self.dense_hairer is not None and np.asarray(self.dense_hairer, dtype=np.float64).shape[1:] != (
                    s + 1 + extra,):
                raise ValueError(f"dense_hairer rows must hold {s + 1 + extra} numbers")
            if self.has_dense_output and (self.dense_matrix().ndim != 2 or self.dense_matrix().shape[0] != s + 1 + extra):
                raise ValueError(f"dense_weights must have {s + 1 + extra} rows, got shape {self.dense_matrix().shape}")
        except ValueError as error:
            return [str(error)]
        full_a, full_c = self.extended_a(), self.extended_c()
        problems = []
        optional = ([self.error_weights] if self.is_embedded else []) + (
            [self.dense_matrix()] if self.has_dense_output else [])
        if not all(np.all(np.isfinite(np.asarray(x, dtype=np.float64))) for x in (full_a, full_c, b, *optional)):
            return ["every coefficient must be finite"]
        if full_c[0] != 0.0:
            problems.append(f"c[0] must be 0 (the first stage is f(t, y)), got {full_c[0]!r}")
        if np.any(np.triu(full_a)[: s] != 0.0) or (extra and np.any(np.triu(full_a)[s + 1:, s + 1:] != 0.0)):
            problems.append("a must be strictly lower triangular (an explicit method)")
        sums, scales = full_a.sum(axis=1), np.abs(full_a).sum(axis=1) + np.abs(full_c)
        for i in np.flatnonzero(np.abs(sums - full_c) > CONDITION_RTOL * np.maximum(scales, 1.0)):
            problems.append(f"row {i}: Σⱼ aᵢⱼ = {sums[i]!r} differs from c = {full_c[i]!r}")
        if problems:
            return problems
        stages_a = full_a[: s + 1, : s + 1]
        checks: list[tuple[str, np.ndarray, int | None]] = [("b", np.concatenate([b, [0.0]]), self.order)]
        if self.error_weights is not None:
            checks.append(("b − error_weights", np.concatenate([b, [0.0]]) - np.asarray(self.error_weights),
                           self.error_order))
        if self.secondary_error_weights is not None:
            checks.append(("b − secondary_error_weights",
                           np.concatenate([b, [0.0]]) - np.asarray(self.secondary_error_weights),
                           self.secondary_error_order))
        for what, weights, order in checks:
            if not (isinstance(order, int) and 1 <= order <= MAX_CHECKED_ORDER):
                problems.append(f"{what}: order must be an integer in 1…{MAX_CHECKED_ORDER}, got {order!r}")
                continue
            problems += self._condition_problems(what, stages_a, weights, order)
        if self.has_dense_output:
            problems += self._dense_problems(full_a)
        if self.exact is not None:
            problems += self.exact.rounding_problems(self.c, self.a, self.b)
        return problems

    @staticmethod
    def _condition_problems(what: str, a: np.ndarray, weights: np.ndarray, order: int, power: int | None = None
                            ) -> list[str]:
        found = []
        for tree, residual, scale in order_condition_residuals(a, weights, order):
            if power is not None:  # coefficient of θ^power: 1/γ(t) where ρ(t) = power, else 0
                residual = residual + (1.0 / tree_density(tree) if tree_order(tree) != power else 0.0)
            if abs(residual) > CONDITION_RTOL * scale:
                found.append(f"{what}: order condition of the tree {tree} (order {tree_order(tree)}) fails by "
                             f"{residual:.3g}")
        return found[:5]

    def _dense_problems(self, full_a: np.ndarray) -> list[str]:
        weights = self.dense_matrix()
        problems = []
        at_one = weights.sum(axis=1)
        if np.any(np.abs(at_one - self.extended_b()) > CONDITION_RTOL * np.maximum(np.abs(weights).sum(axis=1), 1.0)):
            problems.append("dense output: bᵢ(1) must equal the weights b (continuity with y_new)")
        if not (isinstance(self.dense_order, int) and 1 <= self.dense_order <= weights.shape[1]):
            return problems + [f"dense_order must be an integer in 1…{weights.shape[1]}, got {self.dense_order!r}"]
        for k in range(weights.shape[1]):
            problems += self._condition_problems(f"dense output, θ^{k + 1}", full_a, weights[:, k],
                                                 min(self.dense_order, MAX_CHECKED_ORDER), power=k + 1)
        return problems


def exact(text: str) -> float:
    """A coefficient given as exact text (an integer, a fraction "n/d" or a decimal with every published digit),
    rounded once to the nearest double (Python's ``Fraction`` to ``float`` conversion rounds correctly)."""
    return float(Fraction(text))


def from_stage_data(name: str, *, stages: int, nodes: dict[int, str], coupling: dict[int, dict[int, str]],
                    weights: dict[int, str], error_weights: dict[int, str], dense_weights: dict[int, tuple[str, ...]],
                    order: int, error_order: int, dense_order: int, reference: str) -> ButcherTableau:
    """An embedded pair with dense output from sparse data numbered as in the papers (stage 1 first), values as
    exact text (``exact``; absent entries are 0): ``nodes`` {stage: c}; ``coupling`` {stage: {stage: a}} for
    stages 2…s and for the dense-output stages s + 2, …; stage s + 1 is f(t + h, y_new) (its row is b, not
    given); ``weights`` {stage: b}; ``error_weights`` {stage: b − b̂}; ``dense_weights`` {stage: coefficients of
    θ, θ², …} of bᵢ(θ). The main method's c, A and b are also kept exact (``ExactCoefficients``)."""
    total = max([stages + 1, *coupling])
    degree = max(len(row) for row in dense_weights.values())

    def vector(entries: dict[int, str], length: int) -> tuple[float, ...]:
        return tuple(exact(entries[i + 1]) if i + 1 in entries else 0.0 for i in range(length))

    def rationals(entries: dict[int, str], length: int) -> tuple[Fraction, ...]:
        return tuple(Fraction(entries.get(i + 1, "0")) for i in range(length))

    rows = {i: vector(coupling.get(i, {}), total) for i in range(1, total + 1)}
    main = ExactCoefficients(c=rationals(nodes, stages), b=rationals(weights, stages),
                             a=tuple(rationals(coupling.get(i, {}), stages) for i in range(1, stages + 1)))
    return ButcherTableau(
        name=name, order=order, error_order=error_order, dense_order=dense_order, reference=reference,
        c=vector(nodes, stages), a=tuple(rows[i][:stages] for i in range(1, stages + 1)), b=vector(weights, stages),
        error_weights=vector(error_weights, stages + 1),
        dense_c=vector(nodes, total)[stages + 1:], dense_a=tuple(rows[i] for i in range(stages + 2, total + 1)),
        dense_weights=tuple(tuple(exact(x) for x in dense_weights.get(i, ())) + (0.0,) * (
            degree - len(dense_weights.get(i, ()))) for i in range(1, total + 1)),
        exact=main,
    )
