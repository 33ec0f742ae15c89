"""Gauss–Legendre collocation methods (implicit Runge–Kutta) with a fixed-point solve to round-off.

The s-stage Gauss method has order 2s, is symmetric, symplectic, A-stable, and conserves every quadratic
invariant of the system exactly (Cooper 1987; Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd
ed., Thm. IV.2.2 and Thm. VI.4.3). On the linear model the energy ½|v|² + ½k²|r|² is such an invariant (the
Coriolis force does no work), so it is conserved to round-off; Runge–Kutta methods commute with the linear map
(r, v) → (r, p = v + ω×r), so the method is symplectic in the canonical variables as well.

**Solve.** The stage equations Z_i = h Σ_j a_ij f(y + Z_j) are solved by fixed-point iteration, the standard
choice for non-stiff problems (Hairer, Lubich & Wanner §VIII.6.1), starting from Z_i = h c_i f(y). The
iteration goes on to convergence (Hairer, McLachlan & Razakarivony, BIT 48, 231 (2008), §3): it stops when a
sweep changes nothing, or when the increment has not reached a new minimum for ``STALL_SWEEPS`` sweeps once it
is below ``CONVERGED_INCREMENT``: from then on round-off dominates, so the stages are as exact as floating point
allows. (HLW's rule, §VIII.6.1, stops at the first ‖ΔZ‖ that no longer decreases; the two-stage iteration's
increments oscillate as they decay, its matrix h A⊗J is not normal, so a single non-decrease is not yet
round-off.) An earlier exit, once the error estimated from the contraction was below half an ulp, left an error
that is a smooth function of the state, the same from step to step: the linear model's energy drifted linearly,
1.2e-10 (two-stage) and 3.6e-11 (midpoint) in 10⁶ steps at kh 0.5 (``bench.studies.long_time_roundoff``).
What the converged stages still carry is a selection: the rounded iteration map has several fixed points within an
ulp, the iteration stops at the one on the side it came from, and on the linear model at kh 0.5 that leaves an
energy drift of about 1e-3 ε per step (bench/PERF.md "Where the Gauss methods' drift comes from").
ΔZ is measured relative to the state in the oscillator's energy norm, √(k²|Δr|² + |Δv|²)/(k(|x| + |y|) + |vx| +
|vy|), k² = g/L. If the increment exceeds ``DIVERGED_INCREMENT`` or ``MAX_SWEEPS`` sweeps pass, the iteration has
not converged: the step returns NaN and the run is reported ``diverged``.

**Update.** A step is an increment (``make_increment``), h Σ b_i f(y + Z_i) from the converged stages, which the
fixed-step loop adds to the state with compensated summation (``integrators.fixed_step``).

**Limit.** On ẍ = −k²x the iteration map has spectral radius kh·ρ(A) (ρ(A) the spectral radius of the
coefficient matrix), so the solve converges for kh < 1/ρ(A): 2 for the midpoint rule (ρ = ½), 2√3 ≈ 3.46
for the two-stage method (ρ = 1/√12). The methods themselves are A-stable; that solve limit is the
``stability_limit_kh`` they declare, because beyond it this implementation reports divergence. Just below it
the iteration's round-off floor, which grows like ε/(1 − ρ), rises above ``CONVERGED_INCREMENT``: the stability
study measures 3.4625 for the two-stage method against 2√3 = 3.4641 (5e-4 relative) and 1.9993 for the midpoint
rule.
"""

from __future__ import annotations

import math
from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator, state_plus
from foucault_bench.models import Model
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import P_K2

STALL_SWEEPS = 8
"""Sweeps without a new smallest increment after which the iteration has reached its round-off floor."""
CONVERGED_INCREMENT = 1.0e-12
"""A stall counts as the round-off floor only once the smallest increment is below this; above it the
iteration goes on (it is still contracting, however slowly, or it diverges)."""
DIVERGED_INCREMENT = 1.0e3
"""Above this relative increment the iteration has diverged (kh beyond the solve limit)."""
MAX_SWEEPS = 100_000
"""Fixed-point sweeps per step at most (about 10 suffice at kh = 0.5; near the limit ~28/(1 − ρ) are needed for a
contraction factor ρ)."""

SQRT3 = math.sqrt(3.0)


class GaussCollocation(FixedStepIntegrator):
    """Base of the Gauss–Legendre methods: a subclass sets ``collocation_stages`` (1 or 2).

    ``stages`` (evaluations per step) stays ``None``: each step takes as many fixed-point sweeps as its solve
    needs, so ``nfev`` is not reported rather than reported as stages × steps; cost is the measured time.
    """

    family: ClassVar[str] = "gauss-legendre"
    collocation_stages: ClassVar[int]
    symplectic: ClassVar[bool] = True
    conserves_quadratic_invariants: ClassVar[bool] = True

    def make_increment(self, model: Model) -> Callable:
        if self.collocation_stages == 1:
            return _midpoint_increment(model.numba_acceleration)
        if self.collocation_stages == 2:
            return _gauss2_increment(model.numba_acceleration)
        raise NotImplementedError(f"Gauss–Legendre with {self.collocation_stages} stages")

    def make_step(self, model: Model) -> Callable:
        return state_plus(self.make_increment(model))


@jit
def _squared_norm(dx, dy, dvx, dvy, k):
    """k²|Δr|² + |Δv|²: the square of a state increment in the oscillator's energy norm, in which the iteration
    map of ẍ = −k²x is normal, so that its increments shrink monotonically. An increment is √(Σ of these over
    the stages)/scale: one square root per sweep, no ``hypot`` (the terms are far from overflow: a sweep whose
    relative increment passes ``DIVERGED_INCREMENT`` ends the solve)."""
    return k * k * (dx * dx + dy * dy) + dvx * dvx + dvy * dvy


@jit
def _sweep_verdict(change, smallest, stalled):
    """The stopping rule after one fixed-point sweep whose relative increment is ``change`` (module docstring):
    (done, converged, smallest increment so far, sweeps since it was reached)."""
    if change < smallest:
        smallest = change
        stalled = 0
    else:
        stalled += 1
    if change == 0.0 or (stalled >= STALL_SWEEPS and smallest <= CONVERGED_INCREMENT):
        return True, True, smallest, stalled
    return change > DIVERGED_INCREMENT, False, smallest, stalled


def _midpoint_increment(acceleration: Callable) -> Callable:
    """Implicit midpoint rule: y₁ = y₀ + Z, Z = h f(y₀ + Z/2) (c = ½, a = ½, b = 1); iterates on Z/2 and returns
    the increment Z = h f(y₀ + Z/2) evaluated once more at the converged stage."""

    @jit(inline="always")
    def increment(x, y, vx, vy, h, p):
        ax, ay = acceleration(x, y, vx, vy, p)
        k = math.sqrt(p[P_K2])
        scale = k * (abs(x) + abs(y)) + abs(vx) + abs(vy) + 1e-300
        zx, zy, zvx, zvy = 0.5 * h * vx, 0.5 * h * vy, 0.5 * h * ax, 0.5 * h * ay  # Z/2 from c = ½
        smallest = math.inf
        stalled = 0
        converged = False
        for _ in range(MAX_SWEEPS):
            mvx = vx + zvx
            mvy = vy + zvy
            max_, may = acceleration(x + zx, y + zy, mvx, mvy, p)
            nx, ny, nvx, nvy = 0.5 * h * mvx, 0.5 * h * mvy, 0.5 * h * max_, 0.5 * h * may
            change = math.sqrt(_squared_norm(nx - zx, ny - zy, nvx - zvx, nvy - zvy, k)) / scale
            zx, zy, zvx, zvy = nx, ny, nvx, nvy
            done, converged, smallest, stalled = _sweep_verdict(change, smallest, stalled)
            if done:
                break
        if not converged:
            return math.nan, math.nan, math.nan, math.nan
        # the increment h f(y + Z/2) from the converged stage (one evaluation more than 2·Z/2, whose rounding was
        # fed back through the iteration: the energy drifted 6× faster, bench/PERF.md "Round-off")
        fx, fy = acceleration(x + zx, y + zy, vx + zvx, vy + zvy, p)
        return h * (vx + zvx), h * (vy + zvy), h * fx, h * fy

    return increment


GAUSS2_S = SQRT3 / 6.0
"""√3/6: the two-stage Gauss matrix is A = [[¼, ¼ − s], [¼ + s, ¼]]."""
# The nodes c = ½ ∓ √3/6 are not needed: every model is autonomous, so no stage evaluates f at t + c h.


def _gauss2_increment(acceleration: Callable) -> Callable:
    """Two-stage Gauss: c = ½ ∓ √3/6, A = [[¼, ¼ − √3/6], [¼ + √3/6, ¼]], b = (½, ½) (order 4).
    Iterates on the stage derivatives K_i = f(y + h Σ_j a_ij K_j) and returns the increment h(K₁ + K₂)/2.
    The stage sums are written ¼(K₁ + K₂) ∓ s K_(2,1) with one rounded s = √3/6: the coefficients then satisfy
    b_i a_ij + b_j a_ji = b_i b_j exactly, the condition for symplecticity and for conserving quadratic
    invariants (Hairer, Lubich & Wanner, Thm. IV.2.2, VI.4.3), whereas ¼ + s rounds and breaks it by ~1e-17 a
    step, a drift linear in the steps (Hairer, McLachlan & Razakarivony, BIT 48, 231 (2008), §4)."""

    @jit(inline="always")
    def increment(x, y, vx, vy, h, p):
        ax, ay = acceleration(x, y, vx, vy, p)
        k = math.sqrt(p[P_K2])
        scale = k * (abs(x) + abs(y)) + abs(vx) + abs(vy) + 1e-300
        # stage derivatives (k*x = velocity, k*v = acceleration), started at f(y)
        k1x, k1y, k1vx, k1vy = vx, vy, ax, ay
        k2x, k2y, k2vx, k2vy = vx, vy, ax, ay
        smallest = math.inf
        stalled = 0
        converged = False
        for _ in range(MAX_SWEEPS):
            qx, qy, qvx, qvy = 0.25 * (k1x + k2x), 0.25 * (k1y + k2y), 0.25 * (k1vx + k2vx), 0.25 * (k1vy + k2vy)
            u1x = vx + h * (qvx - GAUSS2_S * k2vx)
            u1y = vy + h * (qvy - GAUSS2_S * k2vy)
            u2x = vx + h * (qvx + GAUSS2_S * k1vx)
            u2y = vy + h * (qvy + GAUSS2_S * k1vy)
            b1x, b1y = acceleration(x + h * (qx - GAUSS2_S * k2x), y + h * (qy - GAUSS2_S * k2y), u1x, u1y, p)
            b2x, b2y = acceleration(x + h * (qx + GAUSS2_S * k1x), y + h * (qy + GAUSS2_S * k1y), u2x, u2y, p)
            change = math.sqrt(
                _squared_norm(h * (u1x - k1x), h * (u1y - k1y), h * (b1x - k1vx), h * (b1y - k1vy), k)
                + _squared_norm(h * (u2x - k2x), h * (u2y - k2y), h * (b2x - k2vx), h * (b2y - k2vy), k)
            ) / scale
            k1x, k1y, k1vx, k1vy = u1x, u1y, b1x, b1y
            k2x, k2y, k2vx, k2vy = u2x, u2y, b2x, b2y
            done, converged, smallest, stalled = _sweep_verdict(change, smallest, stalled)
            if done:
                break
        if not converged:
            return math.nan, math.nan, math.nan, math.nan
        half = 0.5 * h
        return half * (k1x + k2x), half * (k1y + k2y), half * (k1vx + k2vx), half * (k1vy + k2vy)

    return increment
