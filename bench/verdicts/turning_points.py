"""Turning points of the swing and the precession rate measured from them, with the interpolation's error
bounds (``bench.verdicts.columns`` turns them into verdict columns).

Turning points (maxima of the radius) are located on a quintic Hermite interpolant of the output grid
(positions, velocities, and accelerations from the model); their azimuths ψ are unwrapped as 2ψ, halved, and
fitted by a straight line in t. The same procedure serves every integrator and the reference.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import BPoly
from scipy.optimize.elementwise import find_root

from foucault_bench.models import Model, PendulumParameters

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
    output interval below a quarter period; ``bench.problems.scenes`` enforces a fifth);
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
    Statistical Methods, §4.1.4.1; integrators/README.md "Measuring the precession rate"). NaN with fewer than 3
    points.
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
