"""Gragg-Bulirsch-Stoer extrapolation: the explicit midpoint rule with Gragg's smoothing step, extrapolated in h².

One *line* of the extrapolation table integrates ż = f(z) (z = (x, y, ẋ, ẏ)) over a step H with n (even)
substeps h = H/n of the explicit midpoint rule started by an Euler step, and ends with Gragg's smoothing step
(Gragg, SIAM J. Numer. Anal. 2, 384 (1965); Hairer, Nørsett & Wanner, Solving ODEs I, 2nd ed., §II.9):

    z₁ = z₀ + h f(z₀),   z_{m+1} = z_{m−1} + 2h f(z_m)  (m = 1 … n−1),   T = (z_{n−1} + z_n + h f(z_n)) / 2.

T has an asymptotic expansion in even powers of h (Gragg; HNW I, §II.9), so the
values T_{j1} of lines with n₁ < n₂ < … are extrapolated to h = 0 by the Aitken-Neville recursion

    T_{j,l+1} = T_{j,l} + (T_{j,l} − T_{j−1,l}) / ((n_j/n_{j−l})² − 1)        (HNW I, §II.9),

and T_{kk} has order 2k. Each line costs n_j evaluations after the shared f(z₀): line j of the table costs
A_j = 1 + n₁ + … + n_j evaluations in all (HNW I, §II.9, the work per step of ODEX's order control).

* ``build_midpoint_line``: one line, compiled from the model's acceleration, in scalars.
* ``extrapolation_weights``: T_{kk} = Σ_j c_j T_{j1} with c_j = Π_{l≠j} n_j²/(n_j² − n_l²), the Lagrange form of
  the same interpolation polynomial in h² evaluated at 0; the fixed-order integrator
  (``FixedOrderExtrapolation``) sums it in four scalars per step, without a table.
* ``oscillator_stability_polynomial`` and ``oscillator_stability_limit``: the stability polynomial R(z) of T_{kk}
  (z = λH on ż = λz) and the first k·H on the undamped oscillator where |R(ikH)| exceeds 1, from the sequence.

The adaptive driver with ODEX's order and step-size control is ``integrators.extrapolation_driver``.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Callable, ClassVar

import numpy as np

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.models import Model
from foucault_bench.models.jit import jit

HARMONIC = "harmonic"
ROMBERG = "romberg"
SEQUENCES = (HARMONIC, ROMBERG)
"""The step-number sequences (HNW I, §II.9): harmonic 2, 4, 6, 8, …
(Deuflhard's choice, ODEX's default ``NSEQU = 1``) and Romberg 2, 4, 8, 16, …"""


def step_numbers(kind: str, lines: int) -> tuple[int, ...]:
    """The first ``lines`` members n₁ < n₂ < … of the sequence ``kind`` (``SEQUENCES``)."""
    if kind not in SEQUENCES:
        raise ValueError(f"unknown step-number sequence {kind!r}; known: {', '.join(SEQUENCES)}")
    if lines < 1:
        raise ValueError(f"an extrapolation table needs at least one line, got {lines}")
    return tuple(2 * (j + 1) if kind == HARMONIC else 2 ** (j + 1) for j in range(lines))


def line_costs(numbers: tuple[int, ...]) -> tuple[int, ...]:
    """A_j = 1 + n₁ + … + n_j: evaluations to compute lines 1 … j of the table (HNW I, §II.9)."""
    return tuple(1 + sum(numbers[: j + 1]) for j in range(len(numbers)))


def _exact_weights(numbers: tuple[int, ...]) -> list[Fraction]:
    weights = []
    for j, nj in enumerate(numbers):
        weight = Fraction(1)
        for l, nl in enumerate(numbers):
            if l != j:
                weight *= Fraction(nj * nj, nj * nj - nl * nl)
        weights.append(weight)
    return weights


def extrapolation_weights(numbers: tuple[int, ...]) -> tuple[float, ...]:
    """c_j with T_{kk} = Σ_j c_j T_{j1}: the Lagrange weights at h² = 0 of the nodes (H/n_j)², exact fractions
    (they sum to 1: consistency) rounded once."""
    return tuple(float(weight) for weight in _exact_weights(numbers))


def build_midpoint_line(acceleration: Callable) -> Callable:
    """The compiled line ``(x, y, vx, vy, ax0, ay0, big_h, n, p) -> (T, f(z₁))``: n midpoint substeps of H/n from the
    state whose acceleration is (ax0, ay0), then Gragg's smoothing step (module docstring); it returns the
    smoothed state T (4 values) and the derivative at the first substep f(z₁) (4 values, for ODEX's stability
    check). n acceleration calls (n ≥ 2); nothing is allocated."""

    @jit(inline="always")
    def midpoint_line(x, y, vx, vy, ax0, ay0, big_h, n, p):
        h = big_h / n
        two_h = 2.0 * h
        # z_{m-1} (previous) and z_m (current); the derivative of z is (vx, vy, ax, ay)
        px, py, pvx, pvy = x, y, vx, vy
        cx, cy, cvx, cvy = x + h * vx, y + h * vy, vx + h * ax0, vy + h * ay0
        ax, ay = acceleration(cx, cy, cvx, cvy, p)
        first = (cvx, cvy, ax, ay)
        for _ in range(n - 1):
            nx, ny, nvx, nvy = px + two_h * cvx, py + two_h * cvy, pvx + two_h * ax, pvy + two_h * ay
            px, py, pvx, pvy = cx, cy, cvx, cvy
            cx, cy, cvx, cvy = nx, ny, nvx, nvy
            ax, ay = acceleration(cx, cy, cvx, cvy, p)
        return (0.5 * (px + cx + h * cvx), 0.5 * (py + cy + h * cvy),
                0.5 * (pvx + cvx + h * ax), 0.5 * (pvy + cvy + h * ay), *first)

    return midpoint_line


def oscillator_stability_polynomial(numbers: tuple[int, ...]) -> list[Fraction]:
    """The coefficients (exact, lowest degree first) of R(z) of T_{kk} on ż = λz, z = λH: the smoothed midpoint
    line as a polynomial in z for each n_j (the recursion of the module docstring with f(z) = λz), combined with
    the Lagrange weights."""
    def add(a: list[Fraction], b: list[Fraction], scale: Fraction = Fraction(1), shift: int = 0) -> list[Fraction]:
        out = a + [Fraction(0)] * max(0, len(b) + shift - len(a))
        for index, value in enumerate(b):
            out[index + shift] += scale * value
        return out

    total: list[Fraction] = []
    for weight, n in zip(_exact_weights(numbers), numbers, strict=True):
        h = Fraction(1, n)  # λh = z/n: multiplying by it shifts the degree by one
        previous, current = [Fraction(1)], [Fraction(1), h]
        for _ in range(n - 1):
            previous, current = current, add(previous, current, 2 * h, 1)
        smoothed = add(add(previous, current), current, h, 1)
        total = add(total, smoothed, weight / 2)
    return total


def oscillator_stability_limit(numbers: tuple[int, ...]) -> float | None:
    """The first k·H > 0 on ẍ = −k²x (eigenvalues ±ik: the one-step map's spectral radius is |R(ikH)|) where
    |R(ikH)| exceeds 1: the smallest positive root of P(y) = |R(iy)|² − 1 = R(iy)R(−iy) − 1, a polynomial in y²
    with exact coefficients; ``None`` when P > 0 for small y (growth at every step size: T_{kk} with k odd)."""
    coefficients = oscillator_stability_polynomial(numbers)
    real = [c * (1 if d % 4 == 0 else -1) if d % 2 == 0 else Fraction(0) for d, c in enumerate(coefficients)]
    imaginary = [c * (1 if d % 4 == 1 else -1) if d % 2 == 1 else Fraction(0) for d, c in enumerate(coefficients)]
    square = [Fraction(0)] * (2 * len(coefficients) - 1)
    for i in range(len(coefficients)):
        for j in range(len(coefficients)):
            square[i + j] += real[i] * real[j] + imaginary[i] * imaginary[j]
    square[0] -= 1
    lowest = next((d for d, c in enumerate(square) if c != 0), None)
    if lowest is None or square[lowest] > 0:
        return None
    roots = np.roots([float(c) for c in reversed(square[lowest:])])
    positive = sorted(r.real for r in roots if abs(r.imag) < 1e-9 * max(1.0, abs(r)) and r.real > 0)
    return float(positive[0]) if positive else None


class FixedOrderExtrapolation(FixedStepIntegrator):
    """Base of the fixed-step, fixed-order extrapolated midpoint rules: T_{kk} at every step H (no error
    control), order 2k. A subclass declares ``step_numbers`` (n₁ … n_k); ``order`` and ``stages`` follow from them,
    and its ``stability_limit_kh`` is checked against the stability polynomial."""

    family: ClassVar[str] = "extrapolation"
    step_numbers: ClassVar[tuple[int, ...]]

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "step_numbers" in cls.__dict__:
            numbers = cls.step_numbers
            if any(n % 2 or n < 2 for n in numbers) or list(numbers) != sorted(set(numbers)):
                raise TypeError(f"{cls.__name__}: step numbers must be even and increasing, got {numbers}")
            cls.order = 2 * len(numbers)
            cls.stages = line_costs(numbers)[-1]

    def make_step(self, model: Model) -> Callable:
        acceleration = model.numba_acceleration
        line = build_midpoint_line(acceleration)
        numbers = self.step_numbers
        weights = extrapolation_weights(numbers)
        lines = len(numbers)

        @jit
        def step(x, y, vx, vy, h, p):
            ax0, ay0 = acceleration(x, y, vx, vy, p)
            sx, sy, svx, svy = 0.0, 0.0, 0.0, 0.0
            for j in range(lines):
                tx, ty, tvx, tvy, _, _, _, _ = line(x, y, vx, vy, ax0, ay0, h, numbers[j], p)
                c = weights[j]
                sx += c * tx
                sy += c * ty
                svx += c * tvx
                svy += c * tvy
            return sx, sy, svx, svy

        return step
