"""Gauss–Legendre collocation methods (implicit Runge–Kutta): fixed-point sweeps, then Newton to round-off.

The s-stage Gauss method has order 2s, is symmetric, symplectic, A-stable, and conserves every quadratic
invariant of the system exactly (Cooper 1987; Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd
ed., Thm. IV.2.2 and Thm. VI.4.3). On the linear model the energy ½|v|² + ½k²|r|² is such an invariant (the
Coriolis force does no work), so it is conserved to round-off; Runge–Kutta methods commute with the linear map
(r, v) → (r, p = v + ω×r), so the method is symplectic in the canonical variables as well.

**Solve.** The stage equations Z_i = h Σ_j a_ij f(y + Z_j) are solved in two phases. First fixed-point sweeps,
the standard choice for non-stiff problems (Hairer, Lubich & Wanner §VIII.6.1), from Z_i = h c_i f(y), until a
sweep changes the stages by less than ``NEWTON_START_INCREMENT``: they converge for kh below the solve limit
(below) and diverge beyond it. Then simplified Newton iterations (Hairer & Wanner, Solving ODEs II, §IV.8,
eq. (8.4)) with the Jacobian of f at y, taken by forward differences of the model's acceleration
(``_difference_jacobian``), until a correction is below ε (``NEWTON_ROUNDOFF``) or no longer decreases once
below ``CONVERGED_INCREMENT`` (round-off dominates it). The system f has the form ṙ = v, v̇ = a(r, v), so the
Newton matrix I − h A⊗J reduces to one 2×2 system (midpoint) or a 2×2 block system (two stages) for the
velocity corrections, solved in closed form.

Why Newton for the last digits (bench/PERF.md "Where the Gauss methods' drift comes from"): fixed-point sweeps
run to convergence stop at one of several fixed points of the rounded iteration map within an ulp, the one on
the side they came from; their last moves are the start's error turned by the iteration matrix h A⊗J once per
sweep, a direction set by the state and kh, so the converged stage carries an error with a mean (on the linear
model at kh 0.5 an energy drift of about 1e-3 ε per step, linear in the steps). A Newton correction from a
stage 1e-4 off lands within round-off of the solution in one or two iterations (on the linear model the
difference Jacobian's error, ~1e-8 relative, leaves ~1e-8 of the previous error: 1e-12 after the first), and
where it lands is set by the rounding of the residual, not by the iteration's path: the linear model's energy
then performs a random walk (Brouwer's law, ``bench.studies.long_time_roundoff``). It is also cheaper than
sweeping to round-off (4 evaluations for the Jacobian, 2-3 iterations), at kh 0.1 as at kh 0.5.
ΔZ is measured relative to the state in the oscillator's energy norm, √(k²|Δr|² + |Δv|²)/(k(|x| + |y|) + |vx| +
|vy|), k² = g/L. If a sweep's increment exceeds ``DIVERGED_INCREMENT``, ``MAX_SWEEPS`` sweeps pass, or Newton
does not converge within ``NEWTON_ITERATIONS`` iterations, the step returns NaN and the run is reported
``diverged``.

**Update.** A step is an increment (``make_increment``), h Σ b_i f(y + Z_i) evaluated once more at the converged
stages, which the fixed-step loop adds to the state with compensated summation (``integrators.fixed_step``).

**Limit.** On ẍ = −k²x the sweeps' iteration map has spectral radius kh·ρ(A) (ρ(A) the spectral radius of the
coefficient matrix), so they converge for kh < 1/ρ(A): 2 for the midpoint rule (ρ = ½), 2√3 ≈ 3.46 for the
two-stage method (ρ = 1/√12). The methods themselves are A-stable, and Newton alone would converge beyond it;
that solve limit is the ``stability_limit_kh`` they declare, because beyond it this implementation's sweeps
diverge and it reports divergence. Just below it the sweeps contract too slowly to reach
``NEWTON_START_INCREMENT`` within ``MAX_SWEEPS`` (about 10/(1 − ρ) sweeps are needed): the stability study
measures 1.99981 for the midpoint rule and 3.46373 for the two-stage method (1e-4 relative below the limits).
"""

from __future__ import annotations

import math
from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator, state_plus
from foucault_bench.models import Model
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import P_K2

NEWTON_START_INCREMENT = 1.0e-4
"""The sweeps hand over to Newton once a sweep changes the stages by less than this (relative): they have shown
that they contract (kh is within the solve limit), and Newton with the difference Jacobian goes from there to
round-off in two iterations (a threshold of 1e-8 cost 6 more sweeps at kh 0.5 and measured the same drift)."""
NEWTON_ROUNDOFF = 2.0**-52
"""A Newton correction below ε (relative) is round-off: the iterate it lands on is the converged stage."""
CONVERGED_INCREMENT = 1.0e-12
"""A Newton correction that no longer decreases counts as round-off only once the previous one is below this."""
DIVERGED_INCREMENT = 1.0e3
"""Above this relative increment the sweeps have diverged (kh beyond the solve limit)."""
MAX_SWEEPS = 100_000
"""Fixed-point sweeps per step at most (about 5 suffice at kh = 0.5; near the limit ~10/(1 − ρ) are needed for a
contraction factor ρ)."""
NEWTON_ITERATIONS = 20
"""Newton iterations per step at most (2-3 reach round-off)."""
DIFFERENCE_STEP = 2.0**-26
"""The forward-difference step of the Jacobian, relative to the state's scale: √ε, which balances the rounding of
the difference (ε/step) against its truncation (step × the second derivative) (Dennis & Schnabel, Numerical
Methods for Unconstrained Optimization and Nonlinear Equations, §5.4)."""

SQRT3 = math.sqrt(3.0)


class GaussCollocation(FixedStepIntegrator):
    """Base of the Gauss–Legendre methods: a subclass sets ``collocation_stages`` (1 or 2).

    ``stages`` (evaluations per step) stays ``None``: each step takes as many sweeps and Newton iterations as its
    solve needs, so ``nfev`` is not reported rather than reported as stages × steps; cost is the measured time.
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
def _newton_converged(change, previous):
    """The stopping rule after a Newton correction of relative size ``change`` following one of ``previous``
    (module docstring)."""
    return change <= NEWTON_ROUNDOFF or (change >= previous and previous <= CONVERGED_INCREMENT)


@jit
def _inverse2(m11, m12, m21, m22):
    """The inverse of the 2×2 matrix [[m11, m12], [m21, m22]] (row-major tuple)."""
    det = m11 * m22 - m12 * m21
    return m22 / det, -m12 / det, -m21 / det, m11 / det


@jit
def _product2(a11, a12, a21, a22, b11, b12, b21, b22):
    """The product of two 2×2 matrices (row-major tuples)."""
    return a11 * b11 + a12 * b21, a11 * b12 + a12 * b22, a21 * b11 + a22 * b21, a21 * b12 + a22 * b22


def _difference_jacobian(acceleration: Callable) -> Callable:
    """``(x, y, vx, vy, ax, ay, p, dr, dv) -> (∂a/∂r row-major, ∂a/∂v row-major)``: the acceleration's Jacobian at
    the state by forward differences (``ax, ay`` the acceleration there), position steps ``dr``, velocity steps
    ``dv``, each divided by the step actually taken ((x + dr) − x, exact)."""

    @jit(inline="always")
    def jacobian(x, y, vx, vy, ax, ay, p, dr, dv):
        step = (x + dr) - x
        bx, by = acceleration(x + step, y, vx, vy, p)
        rxx, ryx = (bx - ax) / step, (by - ay) / step
        step = (y + dr) - y
        bx, by = acceleration(x, y + step, vx, vy, p)
        rxy, ryy = (bx - ax) / step, (by - ay) / step
        step = (vx + dv) - vx
        bx, by = acceleration(x, y, vx + step, vy, p)
        uxx, uyx = (bx - ax) / step, (by - ay) / step
        step = (vy + dv) - vy
        bx, by = acceleration(x, y, vx, vy + step, p)
        uxy, uyy = (bx - ax) / step, (by - ay) / step
        return rxx, rxy, ryx, ryy, uxx, uxy, uyx, uyy

    return jacobian


def _midpoint_increment(acceleration: Callable) -> Callable:
    """Implicit midpoint rule: y₁ = y₀ + Z, Z = h f(y₀ + Z/2) (c = ½, a = ½, b = 1); solves for W = Z/2 and
    returns the increment Z = h f(y₀ + W) evaluated once more at the converged stage."""
    jacobian = _difference_jacobian(acceleration)

    @jit(inline="always")
    def image(x, y, vx, vy, wx, wy, wvx, wvy, hh, p):
        """The sweep W ↦ ½h f(y + W)."""
        mvx = vx + wvx
        mvy = vy + wvy
        fx, fy = acceleration(x + wx, y + wy, mvx, mvy, p)
        return hh * mvx, hh * mvy, hh * fx, hh * fy

    @jit(inline="always")
    def increment(x, y, vx, vy, h, p):
        ax, ay = acceleration(x, y, vx, vy, p)
        k = math.sqrt(p[P_K2])
        scale = k * (abs(x) + abs(y)) + abs(vx) + abs(vy) + 1e-300
        hh = 0.5 * h
        wx, wy, wvx, wvy = hh * vx, hh * vy, hh * ax, hh * ay  # W from c = ½
        change = math.inf
        for _ in range(MAX_SWEEPS):
            nx, ny, nvx, nvy = image(x, y, vx, vy, wx, wy, wvx, wvy, hh, p)
            change = math.sqrt(_squared_norm(nx - wx, ny - wy, nvx - wvx, nvy - wvy, k)) / scale
            wx, wy, wvx, wvy = nx, ny, nvx, nvy
            if change <= NEWTON_START_INCREMENT or not change <= DIVERGED_INCREMENT:  # NaN: diverged
                break
        if not change <= NEWTON_START_INCREMENT:
            return math.nan, math.nan, math.nan, math.nan
        # Newton: (I − ½hJ) ΔW = G, G = ½h f(y + W) − W, J = [[0, I], [Ar, Av]]: the position rows give
        # ΔWr = Gr + ½h ΔWv, the velocity rows (I − ½h Av − ¼h² Ar) ΔWv = Gv + ½h Ar Gr
        rxx, rxy, ryx, ryy, uxx, uxy, uyx, uyy = jacobian(x, y, vx, vy, ax, ay, p, DIFFERENCE_STEP * scale / k,
                                                          DIFFERENCE_STEP * scale)
        hh2 = hh * hh
        i11, i12, i21, i22 = _inverse2(1.0 - hh * uxx - hh2 * rxx, -hh * uxy - hh2 * rxy,
                                       -hh * uyx - hh2 * ryx, 1.0 - hh * uyy - hh2 * ryy)
        previous = math.inf
        converged = False
        for _ in range(NEWTON_ITERATIONS):
            nx, ny, nvx, nvy = image(x, y, vx, vy, wx, wy, wvx, wvy, hh, p)
            gx, gy, gvx, gvy = nx - wx, ny - wy, nvx - wvx, nvy - wvy
            cx = gvx + hh * (rxx * gx + rxy * gy)
            cy = gvy + hh * (ryx * gx + ryy * gy)
            dvx = i11 * cx + i12 * cy
            dvy = i21 * cx + i22 * cy
            dx = gx + hh * dvx
            dy = gy + hh * dvy
            change = math.sqrt(_squared_norm(dx, dy, dvx, dvy, k)) / scale
            wx, wy, wvx, wvy = wx + dx, wy + dy, wvx + dvx, wvy + dvy
            converged = _newton_converged(change, previous)
            if converged:
                break
            previous = change
        if not converged:
            return math.nan, math.nan, math.nan, math.nan
        # the increment h f(y + W) from the converged stage (2·W instead, whose rounding was fed back through the
        # iteration, drifted 6× faster, bench/PERF.md "Round-off"); 2·(½h m) = h m exactly
        nx, ny, nvx, nvy = image(x, y, vx, vy, wx, wy, wvx, wvy, hh, p)
        return 2.0 * nx, 2.0 * ny, 2.0 * nvx, 2.0 * nvy

    return increment


GAUSS2_S = SQRT3 / 6.0
"""√3/6: the two-stage Gauss matrix is A = [[¼, ¼ − s], [¼ + s, ¼]]."""
# The nodes c = ½ ∓ √3/6 are not needed: every model is autonomous, so no stage evaluates f at t + c h.


def _gauss2_increment(acceleration: Callable) -> Callable:
    """Two-stage Gauss: c = ½ ∓ √3/6, A = [[¼, ¼ − √3/6], [¼ + √3/6, ¼]], b = (½, ½) (order 4).
    Solves for the stage derivatives K_i = f(y + h Σ_j a_ij K_j) and returns the increment h(K₁ + K₂)/2 with
    the K_i evaluated once more at the converged stages.
    The stage sums are written ¼(K₁ + K₂) ∓ s K_(2,1) with one rounded s = √3/6: the coefficients then satisfy
    b_i a_ij + b_j a_ji = b_i b_j exactly, the condition for symplecticity and for conserving quadratic
    invariants (Hairer, Lubich & Wanner, Thm. IV.2.2, VI.4.3), whereas ¼ + s rounds and breaks it by ~1e-17 a
    step, a drift linear in the steps (Hairer, McLachlan & Razakarivony, BIT 48, 231 (2008), §4). The Newton
    matrix only steers the corrections; its rounded coefficients do not enter the solution."""
    jacobian = _difference_jacobian(acceleration)

    @jit(inline="always")
    def image(x, y, vx, vy, k1x, k1y, k1vx, k1vy, k2x, k2y, k2vx, k2vy, h, p):
        """The sweep K ↦ f(y + h A K) (k*x = velocity, k*v = acceleration): (f(Y₁), f(Y₂))."""
        qx, qy, qvx, qvy = 0.25 * (k1x + k2x), 0.25 * (k1y + k2y), 0.25 * (k1vx + k2vx), 0.25 * (k1vy + k2vy)
        u1x = vx + h * (qvx - GAUSS2_S * k2vx)
        u1y = vy + h * (qvy - GAUSS2_S * k2vy)
        u2x = vx + h * (qvx + GAUSS2_S * k1vx)
        u2y = vy + h * (qvy + GAUSS2_S * k1vy)
        b1x, b1y = acceleration(x + h * (qx - GAUSS2_S * k2x), y + h * (qy - GAUSS2_S * k2y), u1x, u1y, p)
        b2x, b2y = acceleration(x + h * (qx + GAUSS2_S * k1x), y + h * (qy + GAUSS2_S * k1y), u2x, u2y, p)
        return u1x, u1y, b1x, b1y, u2x, u2y, b2x, b2y

    @jit(inline="always")
    def increment(x, y, vx, vy, h, p):
        ax, ay = acceleration(x, y, vx, vy, p)
        k = math.sqrt(p[P_K2])
        scale = k * (abs(x) + abs(y)) + abs(vx) + abs(vy) + 1e-300
        k1x, k1y, k1vx, k1vy = vx, vy, ax, ay  # started at f(y)
        k2x, k2y, k2vx, k2vy = vx, vy, ax, ay
        change = math.inf
        for _ in range(MAX_SWEEPS):
            u1x, u1y, b1x, b1y, u2x, u2y, b2x, b2y = image(x, y, vx, vy, k1x, k1y, k1vx, k1vy,
                                                           k2x, k2y, k2vx, k2vy, h, p)
            change = math.sqrt(
                _squared_norm(h * (u1x - k1x), h * (u1y - k1y), h * (b1x - k1vx), h * (b1y - k1vy), k)
                + _squared_norm(h * (u2x - k2x), h * (u2y - k2y), h * (b2x - k2vx), h * (b2y - k2vy), k)
            ) / scale
            k1x, k1y, k1vx, k1vy = u1x, u1y, b1x, b1y
            k2x, k2y, k2vx, k2vy = u2x, u2y, b2x, b2y
            if change <= NEWTON_START_INCREMENT or not change <= DIVERGED_INCREMENT:  # NaN: diverged
                break
        if not change <= NEWTON_START_INCREMENT:
            return math.nan, math.nan, math.nan, math.nan
        # Newton: (I − h A⊗J) ΔK = G, G_i = f(Y_i) − K_i, J = [[0, I], [Ar, Av]]: the position rows give
        # ΔKr_i = Gr_i + h Σ_j a_ij ΔKv_j, the velocity rows the 2×2 block system
        # Σ_l P_il ΔKv_l = Gv_i + Ar S_i, P_il = δ_il I − h a_il Av − h² (A²)_il Ar, S_i = h Σ_j a_ij Gr_j,
        # solved by block elimination (P₂₂ = P₁₁ since a₂₂ = a₁₁)
        rxx, rxy, ryx, ryy, uxx, uxy, uyx, uyy = jacobian(x, y, vx, vy, ax, ay, p, DIFFERENCE_STEP * scale / k,
                                                          DIFFERENCE_STEP * scale)
        a12, a21 = 0.25 - GAUSS2_S, 0.25 + GAUSS2_S
        h2 = h * h
        d11, d12, d21 = h2 * (0.0625 + a12 * a21), h2 * (0.5 * a12), h2 * (0.5 * a21)  # h² (A²)_11, _12, _21
        q11, q12, q21, q22 = 1.0 - 0.25 * h * uxx - d11 * rxx, -0.25 * h * uxy - d11 * rxy, \
            -0.25 * h * uyx - d11 * ryx, 1.0 - 0.25 * h * uyy - d11 * ryy  # P₁₁
        p11, p12, p21, p22 = -a12 * h * uxx - d12 * rxx, -a12 * h * uxy - d12 * rxy, \
            -a12 * h * uyx - d12 * ryx, -a12 * h * uyy - d12 * ryy  # P₁₂
        t11, t12, t21, t22 = _product2(-a21 * h * uxx - d21 * rxx, -a21 * h * uxy - d21 * rxy,
                                       -a21 * h * uyx - d21 * ryx, -a21 * h * uyy - d21 * ryy,
                                       *_inverse2(q11, q12, q21, q22))  # P₂₁ P₁₁⁻¹
        w11, w12, w21, w22 = _product2(t11, t12, t21, t22, p11, p12, p21, p22)
        s11, s12, s21, s22 = _inverse2(q11 - w11, q12 - w12, q21 - w21, q22 - w22)  # (P₂₂ − P₂₁ P₁₁⁻¹ P₁₂)⁻¹
        q11, q12, q21, q22 = _inverse2(q11, q12, q21, q22)  # P₁₁⁻¹
        previous = math.inf
        converged = False
        for _ in range(NEWTON_ITERATIONS):
            u1x, u1y, b1x, b1y, u2x, u2y, b2x, b2y = image(x, y, vx, vy, k1x, k1y, k1vx, k1vy,
                                                           k2x, k2y, k2vx, k2vy, h, p)
            g1x, g1y, g1vx, g1vy = u1x - k1x, u1y - k1y, b1x - k1vx, b1y - k1vy
            g2x, g2y, g2vx, g2vy = u2x - k2x, u2y - k2y, b2x - k2vx, b2y - k2vy
            s1x, s1y = h * (0.25 * g1x + a12 * g2x), h * (0.25 * g1y + a12 * g2y)
            s2x, s2y = h * (a21 * g1x + 0.25 * g2x), h * (a21 * g1y + 0.25 * g2y)
            c1x, c1y = g1vx + rxx * s1x + rxy * s1y, g1vy + ryx * s1x + ryy * s1y
            c2x, c2y = g2vx + rxx * s2x + rxy * s2y, g2vy + ryx * s2x + ryy * s2y
            ex, ey = c2x - (t11 * c1x + t12 * c1y), c2y - (t21 * c1x + t22 * c1y)
            e2vx, e2vy = s11 * ex + s12 * ey, s21 * ex + s22 * ey
            ex, ey = c1x - (p11 * e2vx + p12 * e2vy), c1y - (p21 * e2vx + p22 * e2vy)
            e1vx, e1vy = q11 * ex + q12 * ey, q21 * ex + q22 * ey
            e1x, e1y = g1x + h * (0.25 * e1vx + a12 * e2vx), g1y + h * (0.25 * e1vy + a12 * e2vy)
            e2x, e2y = g2x + h * (a21 * e1vx + 0.25 * e2vx), g2y + h * (a21 * e1vy + 0.25 * e2vy)
            change = h * math.sqrt(_squared_norm(e1x, e1y, e1vx, e1vy, k)
                                   + _squared_norm(e2x, e2y, e2vx, e2vy, k)) / scale
            k1x, k1y, k1vx, k1vy = k1x + e1x, k1y + e1y, k1vx + e1vx, k1vy + e1vy
            k2x, k2y, k2vx, k2vy = k2x + e2x, k2y + e2y, k2vx + e2vx, k2vy + e2vy
            converged = _newton_converged(change, previous)
            if converged:
                break
            previous = change
        if not converged:
            return math.nan, math.nan, math.nan, math.nan
        u1x, u1y, b1x, b1y, u2x, u2y, b2x, b2y = image(x, y, vx, vy, k1x, k1y, k1vx, k1vy,
                                                       k2x, k2y, k2vx, k2vy, h, p)
        half = 0.5 * h
        return half * (u1x + u2x), half * (u1y + u2y), half * (b1x + b2x), half * (b1y + b2y)

    return increment
