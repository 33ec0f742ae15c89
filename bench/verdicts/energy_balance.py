"""The energy balance of a run on a model that conserves no energy: the energy's change minus the work of the
non-conservative forces (drag, drive), integrated over each output interval from the run's own state.

For a model whose forces are the Coriolis force, forces with a potential and, on the sphere, the string's
constraint, ``Model.energy`` is conserved and ``bench.verdicts.columns.energy_verdicts`` measures how far a
run strays from it. With drag or a drive (``models.damped_linear``, ``models.driven_linear``) the energy E
changes by the work of the forces that depend on the velocity and are not Coriolis,

    E(t) − E(0) = W(t) = ∫₀ᵗ ṙ·G(r, ṙ) dt',     G = F(r, ṙ) − F(r, 0) + 2ω_c×ṙ   (``Model.numba_remainder``)

(the Coriolis term and the string's force μr do no work: ṙ·(ω×ṙ) = 0 and r·ṙ = 0 on the sphere), so the
residual E(t) − E(0) − W(t), divided by the swing's energy E_swing, is the integrator's energy error, as
(E − E₀)/E_swing is for a conservative model. For the seed's eqs. 4-5 the same residual closes their
dE/dt = (2Ω_E cos φ/L) ẏ(xẋ + yẏ) (models/README.md "The seed's planar model").

**Quadrature: the work along the exact flow of each output interval.** The work over the interval [tᵢ, tᵢ₊₁] is
integrated along the model's exact flow φ started from the run's own state yᵢ (classical RK4 on (r, ṙ, W) in
``substeps`` steps of k·δ ≤ ``SUBSTEP_KH``), so each interval adds E(yᵢ₊₁) − E(φ(yᵢ)) to the residual: the run's
own energy defect over the interval, summed as the energy error of a conservative model sums its own (there
E(φ(yᵢ)) = E(yᵢ)). A quadrature of the run's output instead (an interpolant through the grid points) cannot follow
a force that is not smooth between them: quadratic drag c|ṙ|ṙ has a kink at each turning point, where the speed
passes near zero (it never vanishes there, the swing being a narrow ellipse), and a 6-point Hermite interpolant of
degree 17 through the grid's positions, velocities and accelerations leaves a floor ∝ c², 6.9e-10 at c = 1e-2 /m
over 50 swings of a 3 m pendulum whatever the smoothing speed (1e-3 or 1e-5 m/s), and 3e-8 on a drive narrower
than the bob's travel between grid points. RK4's error over one interval is about (kδ)⁴ kΔ/120 relative (Hairer,
Nørsett & Wanner, *Solving Ordinary Differential Equations I*, §II.1 and II.3), below 1e-15 at ``SUBSTEP_KH``; on
a kink of the force's second derivative a step's error is of order c|ṙ̈|² δ³ instead, below round-off at that δ.
"""

from __future__ import annotations

import functools
import math
from typing import Callable

import numpy as np

from foucault_bench.bench.problems.turning_points import finite_prefix
from foucault_bench.models import Model, PendulumParameters
from foucault_bench.models.base import plane_lift, sphere_height
from foucault_bench.models.jit import jit

SUBSTEP_KH = 4.0e-4
"""Largest k·δ of the RK4 substeps over one output interval (the module docstring)."""


@functools.lru_cache(maxsize=None)
def _interval_work(model: Model) -> Callable:
    """njit ``(y, spacing_s, substeps, p) -> increments``: W over each interval of the grid along the model's
    flow from the row that starts it."""
    acceleration = model.numba_acceleration
    remainder = model.numba_remainder
    lift = jit(sphere_height if model.constrained_to_sphere else plane_lift)

    @jit
    def power(x, y, vx, vy, p):
        z, vz = lift(math, x, y, vx, vy, p)
        gx, gy, gz = remainder(x, y, z, vx, vy, vz, p)
        return vx * gx + vy * gy + vz * gz

    @jit
    def increments(states, spacing_s, substeps, p):
        out = np.empty(states.shape[0] - 1)
        h = spacing_s / substeps
        for i in range(states.shape[0] - 1):
            x, y, vx, vy = states[i, 0], states[i, 1], states[i, 2], states[i, 3]
            work = 0.0
            for _ in range(substeps):
                ax1, ay1 = acceleration(x, y, vx, vy, p)
                w1 = power(x, y, vx, vy, p)
                x2, y2, vx2, vy2 = x + 0.5 * h * vx, y + 0.5 * h * vy, vx + 0.5 * h * ax1, vy + 0.5 * h * ay1
                ax2, ay2 = acceleration(x2, y2, vx2, vy2, p)
                w2 = power(x2, y2, vx2, vy2, p)
                x3, y3, vx3, vy3 = x + 0.5 * h * vx2, y + 0.5 * h * vy2, vx + 0.5 * h * ax2, vy + 0.5 * h * ay2
                ax3, ay3 = acceleration(x3, y3, vx3, vy3, p)
                w3 = power(x3, y3, vx3, vy3, p)
                x4, y4, vx4, vy4 = x + h * vx3, y + h * vy3, vx + h * ax3, vy + h * ay3
                ax4, ay4 = acceleration(x4, y4, vx4, vy4, p)
                w4 = power(x4, y4, vx4, vy4, p)
                x += h / 6.0 * (vx + 2.0 * vx2 + 2.0 * vx3 + vx4)
                y += h / 6.0 * (vy + 2.0 * vy2 + 2.0 * vy3 + vy4)
                vx += h / 6.0 * (ax1 + 2.0 * ax2 + 2.0 * ax3 + ax4)
                vy += h / 6.0 * (ay1 + 2.0 * ay2 + 2.0 * ay3 + ay4)
                work += h / 6.0 * (w1 + 2.0 * w2 + 2.0 * w3 + w4)
            out[i] = work
        return out

    return increments


def cumulative_work(model: Model, params: PendulumParameters, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """W(tᵢ) (J/kg) at every point of a uniform grid ``t`` (finite rows of ``y`` only): the sum of the work along
    the exact flow of each interval from its first row (the module docstring)."""
    n = finite_prefix(y)
    work = np.zeros(n)
    if n < 2:
        return work
    spacing_s = float(t[1] - t[0])
    substeps = max(1, math.ceil(params.pendulum_frequency_rad_s * spacing_s / SUBSTEP_KH))
    states = np.ascontiguousarray(y[:n, :4], dtype=np.float64)
    work[1:] = np.cumsum(_interval_work(model)(states, spacing_s, substeps, params.parameter_vector()))
    return work


def energy_balance_max_rel_error(model: Model, params: PendulumParameters, t: np.ndarray, y: np.ndarray,
                                 energy0_j_kg: float, swing_j_kg: float) -> float:
    """max over the finite grid of |E − E₀ − W| / E_swing (NaN with fewer than two finite rows)."""
    n = finite_prefix(y)
    if n < 2:
        return float("nan")
    values = model.energy_on_rows(y[:n], params.parameter_vector())
    residual = values - energy0_j_kg - cumulative_work(model, params, t[:n], y[:n])
    return float(np.max(np.abs(residual))) / swing_j_kg
