"""The energy balance of a run on a model that conserves no energy: the energy's change minus the work of the
non-conservative forces (drag, drive), integrated along the run's own solution.

For a model whose forces are the Coriolis force, forces with a potential and, on the sphere, the string's
constraint, ``Model.energy`` is conserved and ``bench.verdicts.columns.energy_verdicts`` measures how far a
run strays from it. With drag or a drive (``models.damped_linear``, ``models.driven_linear``) the energy E
changes by the work of the forces that depend on the velocity and are not Coriolis,

    E(t) − E(0) = W(t) = ∫₀ᵗ ṙ·G(r, ṙ) dt',     G = F(r, ṙ) − F(r, 0) + 2ω_c×ṙ   (``Model.numba_remainder``)

(the Coriolis term and the string's force μr do no work: ṙ·(ω×ṙ) = 0 and r·ṙ = 0 on the sphere), so the
residual E(t) − E(0) − W(t), divided by the swing's energy E_swing, is the integrator's energy error, as
(E − E₀)/E_swing is for a conservative model. For the seed's eqs. 4-5 the same residual closes their
dE/dt = (2Ω_E cos φ/L) ẏ(xẋ + yẏ) (models/README.md "The seed's planar model").

**Quadrature.** The output grid has about 8 points a swing, far too coarse for the trapezoidal rule. On each
grid interval the run's trajectory is the local Hermite interpolant of positions, velocities and accelerations
at the 6 nearest grid points (``bench.problems.turning_points.local_hermite``, degree 17, interpolation error
∝ (ΩΔ)¹⁸/18!, below round-off on every built-in scene), and the power ṙ·G is integrated over it by
Gauss-Legendre quadrature with ``QUADRATURE_POINTS`` nodes (exact for polynomials of degree 2·8 − 1 = 15;
Abramowitz & Stegun, Handbook of Mathematical Functions, §25.4.29), so the residual measures the run, not the
quadrature.
"""

from __future__ import annotations

import numpy as np

from foucault_bench.bench.problems.turning_points import finite_prefix, grid_accelerations, local_hermite
from foucault_bench.models import Model, PendulumParameters

QUADRATURE_POINTS = 32
"""Gauss-Legendre nodes per grid interval."""

HERMITE_NODES = 6
"""Grid points of each local interpolant (as for the turning points)."""


def _heights(model: Model, params: PendulumParameters, x, y, vx, vy):
    if not model.constrained_to_sphere:
        return np.zeros_like(x), np.zeros_like(x)
    z = -np.sqrt(params.length_m**2 - x * x - y * y)
    return z, -(x * vx + y * vy) / z


def power_per_kg(model: Model, params: PendulumParameters, states: np.ndarray) -> np.ndarray:
    """ṙ·G (W/kg) at each row (x, y, ẋ, ẏ) of ``states``: the power of the non-Coriolis velocity-dependent forces."""
    x, y, vx, vy = (np.asarray(column, dtype=np.float64) for column in states.T)
    z, vz = _heights(model, params, x, y, vx, vy)
    remainder = model.numba_remainder
    p = params.parameter_vector()
    forces = np.array([remainder(*row, p) for row in zip(x, y, z, vx, vy, vz, strict=True)], dtype=np.float64).reshape(-1, 3)
    return vx * forces[:, 0] + vy * forces[:, 1] + vz * forces[:, 2]


def cumulative_work(model: Model, params: PendulumParameters, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """W(tᵢ) = ∫₀^tᵢ ṙ·G dt (J/kg) at every point of a uniform grid ``t`` (finite rows of ``y`` only; the
    module docstring gives the quadrature)."""
    n = finite_prefix(y)
    work = np.zeros(n)
    if n < 2:
        return work
    nodes = min(HERMITE_NODES, n)
    spacing = float(t[1] - t[0])
    accelerations = grid_accelerations(model, params, y[:n])
    gauss_x, gauss_w = np.polynomial.legendre.leggauss(QUADRATURE_POINTS)
    offsets = 0.5 * (gauss_x + 1.0)  # in [0, 1] of each interval
    start = np.arange(n - 1)
    first = np.clip(start - (nodes // 2 - 1), 0, n - nodes)
    increments = np.empty(n - 1)
    for shift in np.unique(start - first):
        group = np.nonzero(start - first == shift)[0]
        rows = first[group][:, None] + np.arange(nodes)
        interpolant = local_hermite(nodes, int(shift), spacing, y[rows, :2], y[rows, 2:4], accelerations[rows])
        x = (offsets - interpolant.centre) / interpolant.half_width
        position = np.stack([np.polynomial.chebyshev.chebval(x, interpolant.coefficients[:, :, axis]) for axis in (0, 1)],
                            axis=-1)  # (windows, points, 2)
        slope = np.stack([np.polynomial.chebyshev.chebval(x, interpolant.derivative[:, :, axis]) for axis in (0, 1)],
                         axis=-1)
        velocity = slope / (interpolant.half_width * spacing)
        states = np.concatenate([position, velocity], axis=-1).reshape(-1, 4)
        power = power_per_kg(model, params, states).reshape(group.size, QUADRATURE_POINTS)
        increments[group] = 0.5 * spacing * power @ gauss_w
    work[1:] = np.cumsum(increments)
    return work


def energy_balance_max_rel_error(model: Model, params: PendulumParameters, t: np.ndarray, y: np.ndarray,
                                 energy0_j_kg: float, swing_j_kg: float) -> float:
    """max over the finite grid of |E − E₀ − W| / E_swing (NaN with fewer than two finite rows)."""
    n = finite_prefix(y)
    if n < 2:
        return float("nan")
    p = params.parameter_vector()
    energy = model.numba_energy
    values = np.array([energy(row[0], row[1], row[2], row[3], p) for row in y[:n]], dtype=np.float64)
    residual = values - energy0_j_kg - cumulative_work(model, params, t[:n], y[:n])
    return float(np.max(np.abs(residual))) / swing_j_kg
