"""Embedded general Runge-Kutta-Nyström pairs for r̈ = f(r, ṙ), and their compiled adaptive driver.

A general RKN method (Hairer, Nørsett & Wanner, Solving ODEs I, 2nd ed., §II.14) with s stages advances position
and velocity as

    Rᵢ = r + cᵢhṙ + h² Σⱼ āᵢⱼkⱼ,   Ṙᵢ = ṙ + h Σⱼ aᵢⱼkⱼ,   kᵢ = f(Rᵢ, Ṙᵢ),
    r₁ = r + hṙ + h² Σⱼ b̄ⱼkⱼ,     ṙ₁ = ṙ + h Σⱼ bⱼkⱼ,

and an embedded pair estimates the local error as (h² Σⱼ ẽ̄ⱼkⱼ, h Σⱼ ẽⱼkⱼ). ``NystromPair`` holds the coefficients
as exact fractions and checks the simplest order conditions when it is built (HNW I, §II.14: Σⱼ āᵢⱼ = cᵢ²/2,
Σⱼ aᵢⱼ = cᵢ, and for the weights Σb̄ⱼ = 1/2, Σbⱼ = 1, Σbⱼcⱼ = 1/2, Σb̄ⱼcⱼ = 1/6); the observed orders of the
solution and of the estimate are measured by the tests. When the last stage has c = 1 and the weights as its
coefficients it is f(r₁, ṙ₁), the next step's first stage (first same as last).

The driver (``build_driver``), in numba with scalars and arrays allocated once per run: the error norm is the
RMS over (x, y, ẋ, ẏ) of eᵢ/(atolᵢ + rtol·max(|yᵢ|, |y₁ᵢ|)); a step is accepted when it is ≤ 1 and the next
step is h·min(10, max(0.2, 0.9·err^(−1/(q+1)))) (q the estimate's order; no increase right after a rejection),
the controller of scipy's ``solve_ivp`` (Hairer, Nørsett & Wanner I, §II.4); the first step is 0.1/k. The steps
land on every output time (a step that would pass it, or end within 1 % of a step before it, is cut to end on
it; ``integrators.grid_stepping``), as ``gbs``'s do.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from fractions import Fraction
from typing import Callable

import numpy as np
from numba.np.unsafe.ndarray import to_fixed_tuple

from foucault_bench.integrators.grid_stepping import CODE_OK, STATE_SIZE, attempt_code, cut_step, write_initial_rows
from foucault_bench.models import Model
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import PARAMETER_COUNT

SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
"""scipy's step-size controller constants (scipy/integrate/_ivp/rk.py)."""


@dataclass(frozen=True)
class NystromPair:
    """An embedded general RKN pair: ``c``, ``position`` (ā, of h²), ``velocity`` (a, of h), the weights
    ``position_weights`` (b̄) and ``velocity_weights`` (b), the error weights (``position_error``, ``velocity_error``),
    the solution's ``order`` and the estimate's ``error_order``; entries are exact fractions."""

    name: str
    c: tuple[Fraction, ...]
    position: tuple[tuple[Fraction, ...], ...]
    velocity: tuple[tuple[Fraction, ...], ...]
    position_weights: tuple[Fraction, ...]
    velocity_weights: tuple[Fraction, ...]
    position_error: tuple[Fraction, ...]
    velocity_error: tuple[Fraction, ...]
    order: int
    error_order: int

    def __post_init__(self) -> None:
        s = len(self.c)
        problems = []
        for i in range(s):
            if sum(self.velocity[i]) != self.c[i] or sum(self.position[i]) != self.c[i] ** 2 / 2:
                problems.append(f"stage {i + 1}: row sums are not c and c²/2")
            if any(self.velocity[i][j] or self.position[i][j] for j in range(i, s)):
                problems.append(f"stage {i + 1}: not explicit")
        b, bbar = self.velocity_weights, self.position_weights
        bc = sum(x * y for x, y in zip(b, self.c, strict=True))
        bbar_c = sum(x * y for x, y in zip(bbar, self.c, strict=True))
        for value, expected, what in ((sum(bbar), Fraction(1, 2), "Σb̄"), (sum(b), Fraction(1), "Σb"),
                                      (bc, Fraction(1, 2), "Σbc"), (bbar_c, Fraction(1, 6), "Σb̄c")):
            if value != expected:
                problems.append(f"{what} = {value}, not {expected}")
        if problems:
            raise ValueError(f"{self.name}: " + "; ".join(problems))

    @property
    def stages(self) -> int:
        return len(self.c)

    @property
    def first_same_as_last(self) -> bool:
        """The last stage is f(r₁, ṙ₁): c = 1 and the weights as its coefficients."""
        return (self.c[-1] == 1 and self.position[-1] == self.position_weights
                and self.velocity[-1] == self.velocity_weights)

    def arrays(self) -> tuple[np.ndarray, ...]:
        """c, ā, a, b̄, b, ẽ̄, ẽ as float arrays (rounded once from the fractions)."""
        return tuple(np.array(values, dtype=np.float64) for values in (
            self.c, self.position, self.velocity, self.position_weights, self.velocity_weights,
            self.position_error, self.velocity_error))


def build_driver(acceleration: Callable, pair: NystromPair) -> Callable:
    """Compile the adaptive driver (module docstring) around the model's ``acceleration(x, y, vx, vy, p)``."""
    if not pair.first_same_as_last:
        raise ValueError(f"{pair.name}: the driver steps first-same-as-last pairs only")
    c, abar, a, bbar, b, ebar, e = pair.arrays()
    s = pair.stages
    exponent = -1.0 / (pair.error_order + 1)

    @jit
    def driver(y0, parameter_vector, t_out, rtol, atol, h_initial, max_steps, out):
        """Integrate through every time of ``t_out``; returns (code, t reached, nfev, accepted, rejected)."""
        p = to_fixed_tuple(parameter_vector, PARAMETER_COUNT)
        n_out = t_out.shape[0]
        kx = np.empty(s)
        ky = np.empty(s)
        y = np.empty(STATE_SIZE)
        y_new = np.empty(STATE_SIZE)
        for i in range(STATE_SIZE):
            y[i] = y0[i]
        next_out = write_initial_rows(y, t_out, out)
        kx[0], ky[0] = acceleration(y[0], y[1], y[2], y[3], p)
        nfev = 1
        t = 0.0
        h = h_initial
        accepted = 0
        rejected = 0
        attempts = 0
        step_rejected = False
        code = CODE_OK
        while next_out < n_out:
            target = t_out[next_out]
            h, last = cut_step(t, h, target)
            attempts += 1
            code = attempt_code(t, h, attempts, max_steps)
            if code != CODE_OK:
                break
            for i in range(1, s):
                px = y[0] + c[i] * h * y[2]
                py = y[1] + c[i] * h * y[3]
                vx = y[2]
                vy = y[3]
                for j in range(i):
                    px += h * h * abar[i, j] * kx[j]
                    py += h * h * abar[i, j] * ky[j]
                    vx += h * a[i, j] * kx[j]
                    vy += h * a[i, j] * ky[j]
                kx[i], ky[i] = acceleration(px, py, vx, vy, p)
                if i == s - 1:
                    y_new[0], y_new[1], y_new[2], y_new[3] = px, py, vx, vy
            nfev += s - 1
            err = 0.0
            for i in range(STATE_SIZE):
                k = kx if i % 2 == 0 else ky
                total = 0.0
                for j in range(s):
                    total += (ebar[j] * h if i < 2 else e[j]) * k[j]
                scale = atol[i] + rtol * max(abs(y[i]), abs(y_new[i]))
                err += (h * total / scale) ** 2
            err = np.sqrt(err / STATE_SIZE)
            if err <= 1.0:
                factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** exponent)
                if step_rejected:
                    factor = min(1.0, factor)
                t = target if last else t + h
                h *= factor
                step_rejected = False
                accepted += 1
                for i in range(STATE_SIZE):
                    y[i] = y_new[i]
                kx[0] = kx[s - 1]
                ky[0] = ky[s - 1]
                if last:
                    out[next_out, :] = y
                    next_out += 1
            else:
                factor = SAFETY * err ** exponent if err == err else MIN_FACTOR
                h *= max(MIN_FACTOR, factor)
                step_rejected = True
                rejected += 1
        return code, t, nfev, accepted, rejected

    return driver


@functools.lru_cache(maxsize=None)
def compiled_driver(model: Model, pair: NystromPair) -> Callable:
    """The driver for ``model`` and ``pair`` (compiled on first use, cached on disk by numba)."""
    return build_driver(model.numba_acceleration, pair)
