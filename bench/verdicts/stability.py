"""Linear stability and structure of a fixed-step scheme, measured on the compiled loop the benchmark runs.

On the linear model every fixed-step scheme of the suite is a linear map of the state (x, y, ẋ, ẏ) (the
implicit ones up to their solve's round-off), so applying one step to the four unit states gives its matrix M
exactly. The step is taken by the scheme's loop on the linear model (``FixedStepIntegrator.kernel``, one step):
the benchmark's own machine code, which ``foucault-bench run`` has compiled and cached already, where a separate
one-step function would be compiled for every scheme (4.5 s of CPU in a new report, bench/PERF.md). From M:

* ``spectral_growth``: max |λ(M)| − 1, the per-step growth of the fastest-growing mode (≤ 0 up to round-off
  for a stable step); the measured stability limit is the first k·h where it turns positive;
* ``symplecticity_defect``: max |M_cᵀ J M_c − J| for M_c the map in canonical variables (r, p = v + a ẑ×r), zero
  for a symplectic map (Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., Def. VI.2.2);
* ``volume_defect``: |det M − 1|, zero for a volume-preserving map (ibid. §VI.9).
"""

from __future__ import annotations

import math

import numpy as np

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.models import MODELS, PendulumParameters
from foucault_bench.models.parameters import P_OMEGA_Z

GROWTH_TOLERANCE = 1e-10
"""Largest max |λ| − 1 still counted as stable: the eigenvalues of M carry round-off of ~1e-15 and the implicit
schemes' converged stages ~1e-13 (``integrators.gauss``)."""

J = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.eye(2), np.zeros((2, 2))]])


def step_matrix(integrator: FixedStepIntegrator, params: PendulumParameters, step_s: float) -> np.ndarray:
    """The 4×4 matrix of one step of ``integrator`` on the linear model (columns: images of the unit states,
    velocities scaled by k so that the columns are of one size), taken by the scheme's compiled loop (module
    docstring) with no divergence radius. A step that the loop stops as diverged (a NaN position, or a speed at
    its 1e300 bound) leaves its column NaN; either way ``spectral_growth`` of such a matrix is NaN."""
    loop = integrator.kernel(MODELS["linear"])
    p = params.parameter_vector()
    scale = np.array([1.0, 1.0, params.pendulum_frequency_rad_s, params.pendulum_frequency_rad_s])
    matrix = np.empty((4, 4))
    out = np.empty((2, 4))
    no_turning_points = np.empty((0, 3))
    for j in range(4):
        unit = np.zeros(4)
        unit[j] = scale[j]
        out[1] = math.nan  # the loop leaves the row unwritten when the step diverges
        loop(unit, p, step_s, 1, 1, out, False, no_turning_points, math.inf)
        matrix[:, j] = out[1] / scale[j]
    return matrix


def spectral_growth(matrix: np.ndarray) -> float:
    """max |λ| − 1 over the eigenvalues of ``matrix`` (NaN when it holds a non-finite entry)."""
    if not np.all(np.isfinite(matrix)):
        return math.nan
    return float(np.max(np.abs(np.linalg.eigvals(matrix)))) - 1.0


def canonical_matrix(matrix: np.ndarray, params: PendulumParameters) -> np.ndarray:
    """The map in canonical variables (x, y, p_x, p_y), p = v + a ẑ×r (a the vertical rate): T M T⁻¹."""
    a = params.parameter_vector()[P_OMEGA_Z]
    to_canonical = np.eye(4)
    to_canonical[2, 1] = -a
    to_canonical[3, 0] = a
    return to_canonical @ matrix @ np.linalg.inv(to_canonical)


def symplecticity_defect(matrix: np.ndarray, params: PendulumParameters) -> float:
    canonical = canonical_matrix(matrix, params)
    return float(np.max(np.abs(canonical.T @ J @ canonical - J)))


def volume_defect(matrix: np.ndarray) -> float:
    return abs(float(np.linalg.det(matrix)) - 1.0)


def measured_stability_limit(integrator: FixedStepIntegrator, params: PendulumParameters, kh_grid: np.ndarray,
                             resolution_kh: float = 1e-4) -> float:
    """The largest k·h below the first grid point whose step grows (``spectral_growth`` > ``GROWTH_TOLERANCE``),
    refined by bisection to ``resolution_kh``. NaN when the first grid point already grows (unstable at every
    k·h tested); the last grid point when none does."""
    k = params.pendulum_frequency_rad_s

    def grows(kh: float) -> bool:
        growth = spectral_growth(step_matrix(integrator, params, kh / k))
        return not growth <= GROWTH_TOLERANCE

    grid = np.sort(np.asarray(kh_grid, dtype=np.float64))
    first = next((i for i, kh in enumerate(grid) if grows(float(kh))), None)
    if first is None:
        return float(grid[-1])
    if first == 0:
        return math.nan
    low, high = float(grid[first - 1]), float(grid[first])
    while high - low > resolution_kh:
        middle = 0.5 * (low + high)
        low, high = (low, middle) if grows(middle) else (middle, high)
    return low
