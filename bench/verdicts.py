"""Verdicts: what one run's output says about the integrator (the verdict columns of ``bench.schema``).

Every verdict is computed from the solution on the scene's output grid, the same grid for every integrator
of a scene, by one procedure for all integrators and for the reference (``bench.reference``), so that the
comparison is fair and the numbers are deterministic (same inputs → same bits on the same machine).

* **Energy** (``energy_verdicts``): the model's energy E (``Model.energy``: the Jacobi integral on the sphere)
  on the grid, as the relative error (E − E₀)/E_swing. The scale E_swing = E₀ − E_rest is the energy of the
  swing above the bob at rest at the bottom (E_rest = E(0, 0, 0, 0)), so that the figure does not depend on
  where the potential's zero lies: for the planar models E_rest = 0 and E_swing = E₀; for the spherical model
  E₀ ≈ −gL while E_swing ≈ gA²/2L, and dividing by |E₀| would make the same error look 2/θ₀² times smaller.
  Reported: max |·|, least-squares slope in t, and the streamed per-step max rescaled to E_swing.
* **Precession** (``turning_points_from_grid``, ``precession_rate``): turning points of the swing (maxima of
  the radius) located on a quintic Hermite interpolant of the grid (positions, velocities, and accelerations
  from the model), their azimuths ψ unwrapped as 2ψ, halved, and fitted by a straight line in t
  (PHYSICS.md "Measuring the precession rate"). The rate is compared with −Ω_E sin φ and with the
  reference's rate measured the same way on the same grid.
* **Trajectory**: max over the grid of |r − r_other|/A against the exact linear solution, the seed's
  approximate solution (``models.analytic``) and the reference.
* **Convergence** (``observed_order``): the order seen in a sweep of step sizes.

Turning points streamed by some integrators (``Solution.streamed``) are not used for the verdicts: one
measurement on one grid for everyone keeps integrators with and without event detection comparable, and
makes the measurement independent of the code it judges.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from scipy.interpolate import BPoly
from scipy.optimize.elementwise import find_root

from integrators import STATUS_DIVERGED, STATUS_OK, Solution
from models import Model, PendulumParameters
from models.analytic import linear_exact, seed_approximate

if TYPE_CHECKING:  # imported for annotations only: bench.reference imports this module
    from bench.reference import Reference
    from bench.scenes import Scene

NAN = math.nan


# --- turning points and the precession rate ---------------------------------------------------------------------


def finite_prefix(y: np.ndarray) -> int:
    """Number of leading rows of ``y`` that are finite (all rows for a run that did not diverge)."""
    bad = np.nonzero(~np.all(np.isfinite(y), axis=1))[0]
    return int(bad[0]) if bad.size else int(y.shape[0])


def grid_accelerations(model: Model, params: PendulumParameters, y: np.ndarray) -> np.ndarray:
    """(ẍ, ÿ) in m/s² of ``model`` at every row (x, y, ẋ, ẏ) of ``y``: array (n, 2)."""
    acceleration = model.numba_acceleration
    p = params.parameter_vector()
    return np.array([acceleration(row[0], row[1], row[2], row[3], p) for row in y], dtype=np.float64).reshape(-1, 2)


def turning_points_from_grid(t: np.ndarray, y: np.ndarray, accelerations: np.ndarray,
                             include_release: bool) -> np.ndarray:
    """Turning points (maxima of the radius |r|) of a trajectory sampled on a grid: array (n, 3) of (t, x, y).

    Between grid points the trajectory is the quintic Hermite interpolant of position, velocity and
    acceleration (``quintic_hermite``; Hermite interpolation, e.g. Burden & Faires, Numerical Analysis, §3.4).
    A maximum of the radius lies in every grid interval where r·ṙ changes sign from + to − (this needs an
    output interval below a quarter period; ``bench.scenes`` enforces a fifth);
    its time is the root of r·ṙ of the interpolant there (Chandrupatla's bracketing method,
    ``scipy.optimize.elementwise.find_root``), solved in the time offset from the interval's start so that the
    tolerance does not grow with t. ``include_release`` prepends (0, x₀, y₀): a release from rest is a turning
    point. Rows of ``y`` after the first non-finite one are ignored.
    """
    n = finite_prefix(y)
    t, y, accelerations = t[:n], y[:n], accelerations[:n]
    release = y[:1, :2] if include_release and n else np.empty((0, 2))
    release_rows = np.column_stack([t[: release.shape[0]], release])
    if n < 2:
        return release_rows
    radial = y[:, 0] * y[:, 2] + y[:, 1] * y[:, 3]
    start = np.nonzero((radial[:-1] > 0.0) & (radial[1:] <= 0.0))[0]
    if start.size == 0:
        return release_rows
    position = quintic_hermite(t, y[:, :2], y[:, 2:4], accelerations)
    velocity = position.derivative()
    t0 = t[start]

    def radial_velocity(offset: np.ndarray, origin: np.ndarray) -> np.ndarray:
        when = origin + offset
        return np.sum(position(when) * velocity(when), axis=-1)

    offset = t[start + 1] - t0  # where r·ṙ is exactly 0 at the grid point, that point is the turning point
    bracketed = radial[start + 1] != 0.0
    if np.any(bracketed):
        roots = find_root(radial_velocity, (np.zeros(int(bracketed.sum())), offset[bracketed]), args=(t0[bracketed],))
        offset[bracketed] = roots.x
    when = t0 + offset
    return np.vstack([release_rows, np.column_stack([when, position(when)])])


def quintic_hermite(t: np.ndarray, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> BPoly:
    """The piecewise quintic matching position, velocity and acceleration at every grid time, as a ``BPoly``.

    Bernstein coefficients of the quintic on [t_i, t_i + h] follow from the end-point derivatives of a Bézier
    curve, B'(0) = 5(b₁ − b₀)/h and B''(0) = 20(b₂ − 2b₁ + b₀)/h², and symmetrically at the right end
    (Farin, Curves and Surfaces for CAGD, 5th ed., §5.3): b₀ = p₀, b₁ = p₀ + hv₀/5, b₂ = p₀ + 2hv₀/5 + h²a₀/20,
    b₃ = p₁ − 2hv₁/5 + h²a₁/20, b₄ = p₁ − hv₁/5, b₅ = p₁. The same interpolant as
    ``BPoly.from_derivatives``, built in one vectorised step instead of a Python loop over the intervals.
    """
    h = np.diff(t)[:, None]
    p0, p1 = position[:-1], position[1:]
    v0, v1 = velocity[:-1], velocity[1:]
    a0, a1 = acceleration[:-1], acceleration[1:]
    coefficients = np.stack([
        p0,
        p0 + h * v0 / 5.0,
        p0 + 2.0 * h * v0 / 5.0 + h * h * a0 / 20.0,
        p1 - 2.0 * h * v1 / 5.0 + h * h * a1 / 20.0,
        p1 - h * v1 / 5.0,
        p1,
    ])
    return BPoly(coefficients, t)


def least_squares_slope(x: np.ndarray, y: np.ndarray) -> float:
    """Slope of the least-squares line through (x, y), computed on centred data (NaN if x does not vary)."""
    x_centred = np.asarray(x, dtype=np.float64) - np.mean(x)
    spread = float(np.dot(x_centred, x_centred))
    return float(np.dot(x_centred, np.asarray(y, dtype=np.float64) - np.mean(y))) / spread if spread > 0 else NAN


def precession_rate(turning_points: np.ndarray) -> tuple[float, float]:
    """Swing-plane rate (rad/s, counter-clockwise about up positive) and its standard error, from turning points.

    ψ = atan2(y, x) of each turning point (the frame is x South, y East, z Up, so ψ grows counter-clockwise
    seen from above); consecutive turning points lie at opposite ends of the swing, ψ and ψ + π, so 2ψ is
    unwrapped and halved; the rate is the least-squares slope of ψ against t, computed on centred data, with
    the usual standard error √(Σ residual² / (N − 2) / Σ(t − t̄)²) (e.g. NIST/SEMATECH e-Handbook of
    Statistical Methods, §4.1.4.1; PHYSICS.md "Measuring the precession rate"). NaN with fewer than 3 points.
    """
    points = np.asarray(turning_points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 3:
        return NAN, NAN
    t = points[:, 0]
    azimuth = 0.5 * np.unwrap(2.0 * np.arctan2(points[:, 2], points[:, 1]))
    slope = least_squares_slope(t, azimuth)
    if math.isnan(slope):
        return NAN, NAN
    t_centred = t - t.mean()
    residual = azimuth - azimuth.mean() - slope * t_centred
    stderr = math.sqrt(float(np.dot(residual, residual)) / (t.size - 2) / float(np.dot(t_centred, t_centred)))
    return slope, stderr


HERMITE_ERROR_WEIGHT = 1.0 / (720.0 * 64.0)
"""max of θ³(1−θ)³/6! on [0, 1]: the quintic Hermite error is f⁽⁶⁾(ξ)·θ³(1−θ)³Δ⁶/6! (Burden & Faires §3.4)."""
HERMITE_ERROR_SLOPE_WEIGHT = 3.0 / (25.0 * math.sqrt(5.0)) / 720.0
"""max |d/dθ θ³(1−θ)³| / 6!: with u = θ(1−θ) the derivative is 3u²√(1−4u), largest at u = 1/5: 3/(25√5) ≈ 0.0537."""


def turning_time_error_bound(params: PendulumParameters, output_interval_s: float) -> float:
    """Bound (s) on the error of a turning point's time located on the grid (linear model, release at rest).

    The radial part of the quintic Hermite error, ≤ Ω⁶AΔ⁶θ³(1−θ)³/6!, has a slope ≤ Ω⁶AΔ⁵·0.0537/6! that moves
    the maximum of the radius, whose curvature is Ω²A, by δ ≤ 0.0537·Ω⁴Δ⁵/6!.
    """
    big_omega = math.hypot(params.pendulum_frequency_rad_s, params.vertical_rate_rad_s)
    return HERMITE_ERROR_SLOPE_WEIGHT * big_omega**4 * output_interval_s**5


def azimuth_error_bound(params: PendulumParameters, output_interval_s: float) -> float:
    """Bound (rad) on the azimuth error of one turning point located on the grid, linear model, release at rest.

    The exact motion is z = e^{−iat} w with w = A(c₊e^{iΩs} + c₋e^{−iΩs}), c± = (1 ± a/Ω)/2 (``models.analytic``),
    so z⁽⁶⁾ = e^{−iat}(d/dt − ia)⁶ w. Two effects move the measured azimuth: (i) the tangential part of the
    interpolation error: |Im (d/dt − ia)⁶ w| = A|sin Ωs|·|c₊(Ω−a)⁶ − c₋(Ω+a)⁶| ≈ 5aΩ⁵A|sin Ωs|, bounded here
    by 7aΩ⁵A, gives 7(a/Ω)(ΩΔ)⁶/(6!·64); (ii) the time error δ of ``turning_time_error_bound``: the azimuth is
    stationary at a turning point, so the pair (t + δ, ψ) sits a·δ off the line ψ₀ − a t. The bound is their
    sum; for small swings of the other models it holds to leading order.
    """
    a = abs(params.vertical_rate_rad_s)
    big_omega = math.hypot(params.pendulum_frequency_rad_s, a)
    tangential = 7.0 * (a / big_omega) * (big_omega * output_interval_s) ** 6 * HERMITE_ERROR_WEIGHT
    return tangential + a * turning_time_error_bound(params, output_interval_s)


def rate_error_bound(turning_times_s: np.ndarray, azimuth_error_rad: float) -> float:
    """Worst-case error (rad/s) of the least-squares slope when every azimuth errs by at most ``azimuth_error_rad``.

    The slope is Σ(t − t̄)ψ / Σ(t − t̄)², so errors e_i with |e_i| ≤ ε move it by at most ε Σ|t − t̄| / Σ(t − t̄)²
    (≈ 3ε/T over a span T): a bound that holds for systematic errors too, unlike the standard error.
    """
    t_centred = np.asarray(turning_times_s, dtype=np.float64) - np.mean(turning_times_s)
    return azimuth_error_rad * float(np.sum(np.abs(t_centred))) / float(np.dot(t_centred, t_centred))


def rate_scale(params: PendulumParameters) -> float:
    """Normaliser (rad/s) of precession-rate errors: Ω_E|sin φ|, or Ω_E at the equator (NaN without rotation)."""
    scale = abs(params.vertical_rate_rad_s)
    if scale == 0.0:
        scale = params.earth_rate_rad_s
    return scale if scale > 0.0 else NAN


# --- energy ------------------------------------------------------------------------------------------------------


def energy_scale(model: Model, params: PendulumParameters) -> tuple[float, float]:
    """(E₀, E_swing) in J/kg: the energy at release and the swing's energy above the bob at rest at the bottom."""
    p = params.parameter_vector()
    energy0 = float(model.numba_energy(*params.initial_state(), p))
    swing = energy0 - float(model.numba_energy(0.0, 0.0, 0.0, 0.0, p))
    return energy0, (swing if swing > 0.0 else abs(energy0) or 1.0)


def energy_verdicts(model: Model, params: PendulumParameters, solution: Solution) -> dict[str, float | None]:
    """Relative energy error (E − E₀)/E_swing on the finite part of the output grid: max, drift, streamed max.

    The drift is the least-squares slope (1/s) of the relative error against t. ``energy_max_rel_error_steps``
    is the streamed per-step max, which the fixed-step loop normalises by the same E_swing; it is ``None`` when
    the integrator does not stream it. For a model that conserves no energy (the seed's eqs. 4-5) the numbers mix the model's own drift with the integrator's (``energy_conserved`` = 0).
    """
    n = finite_prefix(solution.y)
    energy0, swing = energy_scale(model, params)
    p = params.parameter_vector()
    energy = model.numba_energy
    values = np.array([energy(row[0], row[1], row[2], row[3], p) for row in solution.y[:n]], dtype=np.float64)
    relative = (values - energy0) / swing
    drift = least_squares_slope(solution.t[:n], relative) if n >= 2 else NAN
    streamed = solution.streamed.energy_max_rel_error if solution.streamed is not None else None
    return {
        "energy_conserved": int(model.conserves_energy),
        "energy_max_rel_error": float(np.max(np.abs(relative))) if n else NAN,
        "energy_drift_per_s": drift,
        "energy_max_rel_error_steps": None if streamed is None else float(streamed),
    }


# --- trajectory gaps ---------------------------------------------------------------------------------------------


def max_position_gap(y: np.ndarray, other: np.ndarray, amplitude_m: float) -> float:
    """max over rows of |r − r_other| / A (positions are the first two columns); NaN if no row is finite."""
    n = min(finite_prefix(y), finite_prefix(other))
    if n == 0:
        return NAN
    gap = np.hypot(y[:n, 0] - other[:n, 0], y[:n, 1] - other[:n, 1])
    return float(np.max(gap)) / amplitude_m


def released_from_rest(params: PendulumParameters) -> bool:
    return params.release_velocity_m_s == (0.0, 0.0)


# --- all verdicts of one run -------------------------------------------------------------------------------------


VERDICT_KEYS = (
    "energy_conserved",
    "energy_max_rel_error",
    "energy_drift_per_s",
    "energy_max_rel_error_steps",
    "precession_rate_rad_s",
    "precession_rate_error",
    "precession_rate_ref_error",
    "analytic_gap_exact",
    "analytic_gap_seed",
    "reference_error",
)


def compute_verdicts(scene: "Scene", solution: Solution, reference: "Reference | None") -> dict[str, Any]:
    """The verdict columns of ``bench.schema`` for one run (plus ``precession_rate_stderr_rad_s`` and
    ``turning_points``, the count used for the rate).

    * failed run: only ``energy_conserved`` (a property of the model); everything else NaN;
    * diverged run: energy and trajectory gaps over the grid up to the last finite row (lower bounds of what
      the run did), precession NaN (the swing near a divergence is no longer a pendulum's);
    * ``analytic_gap_*`` only for a planar model released from rest: the closed forms assume the release, and
      for the spherical model the gap would measure the model (its finite-amplitude period), not the run;
      for the seed's eqs. 4-5, ``analytic_gap_seed`` is the comparison the seed itself makes (its §4);
    * ``reference_error`` and ``precession_rate_ref_error`` only with a reference on the same grid.
    """
    model = scene.model_object
    params = scene.params
    verdicts: dict[str, Any] = dict.fromkeys(VERDICT_KEYS, NAN)
    verdicts.update(energy_conserved=int(model.conserves_energy), energy_max_rel_error_steps=None,
                    precession_rate_stderr_rad_s=NAN, turning_points=0)
    if solution.status not in (STATUS_OK, STATUS_DIVERGED):
        return verdicts
    t, y = np.asarray(solution.t, dtype=np.float64), np.asarray(solution.y, dtype=np.float64)
    if reference is not None and (reference.t.shape != t.shape or not np.array_equal(reference.t, t)):
        raise ValueError(f"scene {scene.name}: the solution's output grid differs from the reference's")
    verdicts.update(energy_verdicts(model, params, solution))
    amplitude = params.amplitude_m
    if released_from_rest(params) and not model.constrained_to_sphere:
        verdicts["analytic_gap_exact"] = max_position_gap(y, linear_exact(params, t), amplitude)
        verdicts["analytic_gap_seed"] = max_position_gap(y, seed_approximate(params, t), amplitude)
    if reference is not None:
        verdicts["reference_error"] = max_position_gap(y, reference.y, amplitude)
    if solution.status == STATUS_OK:
        points = turning_points_from_grid(t, y, grid_accelerations(model, params, y), released_from_rest(params))
        rate, stderr = precession_rate(points)
        scale = rate_scale(params)
        verdicts.update(
            precession_rate_rad_s=rate,
            precession_rate_stderr_rad_s=stderr,
            turning_points=int(points.shape[0]),
            precession_rate_error=abs(rate - params.textbook_precession_rate_rad_s) / scale,
        )
        if reference is not None:
            verdicts["precession_rate_ref_error"] = abs(rate - reference.precession_rate_rad_s) / scale
    return verdicts


# --- convergence -------------------------------------------------------------------------------------------------


def observed_order(step_sizes: Sequence[float], errors: Sequence[float], *, max_error: float = 0.1,
                   finest: int = 4, slope_drop: float = 0.8) -> float:
    """Order of convergence p in error ≈ C hᵖ seen in a sweep: the least-squares slope of log error on log h.

    Rule (documented so that tests and ``check`` agree on it):

    1. drop points whose step or error is not finite and positive, and points with error > ``max_error``
       (default 0.1 of the amplitude or of the rate: the error has saturated or is far from asymptotic);
    2. round-off: going from the largest step to the smallest, the first local slope (between neighbouring
       steps) below ``slope_drop`` (0.8) times the median of the local slopes before it marks the onset of
       round-off (the error stops falling as h shrinks); the finer point of that pair and the coarser one, whose
       error already carries part of the round-off, are dropped together with every finer point;
    3. pre-asymptotic: fit only the ``finest`` (default 4) smallest remaining steps, where the higher-order
       terms have died out most.

    Returns NaN when fewer than 2 points remain. Repeated step sizes are averaged in log space.
    """
    h = np.asarray(step_sizes, dtype=np.float64)
    e = np.asarray(errors, dtype=np.float64)
    if h.shape != e.shape:
        raise ValueError("step_sizes and errors must have the same length")
    keep = np.isfinite(h) & (h > 0) & np.isfinite(e) & (e > 0) & (e <= max_error)
    log_h, inverse = np.unique(np.log(h[keep]), return_inverse=True)
    log_e = np.bincount(inverse, weights=np.log(e[keep])) / np.maximum(np.bincount(inverse), 1)
    log_h, log_e = log_h[::-1], log_e[::-1]  # largest step first
    local = np.diff(log_e) / np.diff(log_h)  # local[m]: slope between points m and m + 1
    for m in range(1, local.size):
        if local[m] < slope_drop * np.median(local[:m]):
            log_h, log_e = log_h[:m], log_e[:m]
            break
    log_h, log_e = log_h[-finest:], log_e[-finest:]
    return least_squares_slope(log_h, log_e) if log_h.size >= 2 else NAN
