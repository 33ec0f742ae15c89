"""Turning points of the swing and the precession rate measured from them, with the interpolation's error
bounds (``bench.verdicts.columns`` turns them into verdict columns).

Turning points (maxima of the radius) are located on a local Hermite interpolant of the output grid
(positions, velocities, and accelerations from the model); their azimuths ψ are unwrapped as 2ψ, halved, and
fitted by a straight line in t. The same procedure serves every integrator and the reference.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.polynomial import chebyshev

from foucault_bench.bench.problems.turning_point_roots import radial_velocity_roots
from foucault_bench.models import Model, PendulumParameters

NAN = math.nan

# --- turning points and the precession rate ---------------------------------------------------------------------


def finite_prefix(y: np.ndarray) -> int:
    """Number of leading rows of ``y`` that are finite (all rows for a run that did not diverge)."""
    bad = np.nonzero(~np.all(np.isfinite(y), axis=1))[0]
    return int(bad[0]) if bad.size else int(y.shape[0])


def grid_accelerations(model: Model, params: PendulumParameters, y: np.ndarray) -> np.ndarray:
    """(ẍ, ÿ) in m/s² of ``model`` at every row (x, y, ẋ, ẏ) of ``y``: array (n, 2)."""
    return model.acceleration_on_rows(y, params.parameter_vector())


HERMITE_NODES = 6
"""Grid points each local interpolant uses, 3 on each side of the interval that holds the turning point."""


def turning_points_from_grid(t: np.ndarray, y: np.ndarray, accelerations: np.ndarray,
                             include_release: bool) -> np.ndarray:
    """Turning points (maxima of the radius |r|) of a trajectory sampled on a uniform grid: array (n, 3) of
    (t, x, y).

    A maximum of the radius lies in every grid interval where r·ṙ changes sign from + to − (this needs an
    output interval below a quarter period; ``bench.problems.scene`` enforces a fifth). Around each such
    interval the trajectory is the Hermite interpolant of position, velocity and acceleration at the
    ``HERMITE_NODES`` nearest grid points (``local_hermite``: degree 17, interpolation error ∝ (ΩΔ)¹⁸/18!, below
    round-off on every built-in scene; Burden & Faires, Numerical Analysis, §3.4), and the turning point is the
    root of r·ṙ of that interpolant (Chandrupatla's bracketing method as ``scipy.optimize.elementwise.find_root``
    runs it, compiled: ``bench.problems.turning_point_roots``), solved in the offset from the interval's start so
    that the tolerance does not grow with t.
    ``include_release`` prepends (0, x₀, y₀): a release from rest is a turning point. Rows of ``y`` after the
    first non-finite one are ignored.
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
    spacing = t[1] - t[0]
    if not np.allclose(np.diff(t), spacing, rtol=1e-9, atol=0.0):
        raise ValueError("turning points are located on a uniform output grid")
    nodes = min(HERMITE_NODES, n)
    # the window of ``nodes`` grid points around each interval, shifted inwards at the ends of the grid
    first = np.clip(start - (nodes // 2 - 1), 0, n - nodes)
    when = t[start + 1].copy()  # where r·ṙ is exactly 0 at the grid point, that point is the turning point
    where = y[start + 1, :2].copy()
    bracketed = radial[start + 1] != 0.0
    for shift in np.unique(start - first):
        group = np.nonzero(bracketed & (start - first == shift))[0]
        if group.size == 0:
            continue
        rows = first[group][:, None] + np.arange(nodes)
        interpolant = local_hermite(nodes, int(shift), spacing, y[rows, :2], y[rows, 2:4], accelerations[rows])
        roots = interpolant.radial_velocity_roots()
        when[group] = t[start[group]] + roots * spacing
        where[group] = interpolant.position(roots)
    return np.vstack([release_rows, np.column_stack([when, where])])


class LocalHermite:
    """Hermite interpolants of many windows at once, as Chebyshev series in x ∈ [−1, 1] over each window;
    evaluated at ``offset`` ∈ [0, 1], the fraction of the grid interval that starts at the window's node
    ``shift``."""

    def __init__(self, coefficients: np.ndarray, nodes: int, shift: int) -> None:
        self.coefficients = coefficients  # (degree + 1, windows, 2)
        self.derivative = chebyshev.chebder(coefficients)
        self.half_width = 0.5 * (nodes - 1)
        self.centre = self.half_width - shift

    def _x(self, offset: np.ndarray) -> np.ndarray:
        return (offset - self.centre) / self.half_width

    def position(self, offset: np.ndarray) -> np.ndarray:
        x = self._x(np.asarray(offset, dtype=np.float64))
        return np.stack([chebyshev.chebval(x, self.coefficients[:, :, axis], tensor=False) for axis in (0, 1)],
                        axis=-1)

    def radial_velocity_roots(self) -> np.ndarray:
        """The offset in [0, 1] where r·dr/dx of each window's interpolant vanishes (it changes sign between 0 and 1
        in every window); NaN where it does not."""
        return radial_velocity_roots(np.ascontiguousarray(self.coefficients), np.ascontiguousarray(self.derivative),
                                     self.centre, self.half_width)


@functools.lru_cache(maxsize=None)
def _hermite_system(nodes: int) -> np.ndarray:
    """Inverse of the confluent Chebyshev–Vandermonde matrix of ``nodes`` equispaced nodes on [−1, 1] (rows 3j,
    3j + 1, 3j + 2: T_k, T_k′ and T_k″ at node j, k = 0 … 3·nodes − 1), in extended precision (``np.longdouble``).

    The matrix is ill-conditioned (2.5e5 for 6 nodes): an inverse rounded to double carries relative errors of
    that times ε, which turn into noise of ~1e-11 of the amplitude on the interpolant. It is therefore inverted
    with 40 significant digits (mpmath) and applied in extended precision, which leaves the interpolant within a
    few ε of the data's own round-off."""
    import mpmath

    size = 3 * nodes
    with mpmath.workdps(40):
        x = [mpmath.mpf(2 * j) / (nodes - 1) - 1 for j in range(nodes)]
        matrix = mpmath.matrix(size, size)
        for k in range(size):
            power_series = chebyshev.cheb2poly(np.eye(size)[k])  # integer coefficients, exact in double
            for order in range(3):
                coefficients = [int(c) for c in np.polynomial.polynomial.polyder(power_series, order)]
                for j, node in enumerate(x):
                    matrix[3 * j + order, k] = mpmath.polyval(coefficients[::-1], node)
        inverse = matrix**-1
        return np.array([[np.longdouble(mpmath.nstr(inverse[i, j], 30)) for j in range(size)] for i in range(size)],
                        dtype=np.longdouble)


def local_hermite(nodes: int, shift: int, spacing_s: float, position: np.ndarray, velocity: np.ndarray,
                  acceleration: np.ndarray) -> LocalHermite:
    """The Hermite interpolants through ``position``, ``velocity`` and ``acceleration`` (each (windows, nodes,
    2)) at ``nodes`` equispaced grid points ``spacing_s`` apart; with x = (u − centre)/half-width in grid units
    u, d/dx = half-width·Δ·d/dt."""
    scale = 0.5 * (nodes - 1) * spacing_s
    data = np.stack([position, scale * velocity, scale * scale * acceleration], axis=2)  # (windows, nodes, 3, 2)
    windows = data.shape[0]
    conditions = np.moveaxis(data.reshape(windows, 3 * nodes, 2), 1, 0).reshape(3 * nodes, 2 * windows)
    # one matrix product (terms × conditions)·(conditions × 2·windows), summed in the conditions' order
    coefficients = np.matmul(_hermite_system(nodes), conditions.astype(np.longdouble))
    return LocalHermite(coefficients.astype(np.float64).reshape(3 * nodes, windows, 2), nodes, shift)


def least_squares_slope(x: np.ndarray, y: np.ndarray) -> float:
    """Slope of the least-squares line through (x, y), computed on centred data (NaN if x does not vary)."""
    x_centred = np.asarray(x, dtype=np.float64) - np.mean(x)
    spread = float(np.dot(x_centred, x_centred))
    return float(np.dot(x_centred, np.asarray(y, dtype=np.float64) - np.mean(y))) / spread if spread > 0 else NAN


def unwrapped_azimuth(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Azimuths ψ (rad) of the points (x, y) of a swing, continuous modulo π: ψ₀ = atan2(y₀, x₀) plus half the
    running sum of the doubled-angle turns arg((x_k + iy_k)²·conj((x_{k−1} + iy_{k−1})²)).

    Summing the small turns keeps the round-off at a few ε of the total turn. Unwrapping 2·atan2 instead adds
    a multiple of the rounded 2π at every branch-cut crossing, and a swing released East or West (2ψ ≈ ±π)
    crosses the cut at nearly every turning point: after n points that error is ~n·ε·π (6e-14 rad after 500).
    """
    doubled = (np.asarray(x, dtype=np.float64) + 1j * np.asarray(y, dtype=np.float64)) ** 2
    turns = np.angle(doubled[1:] * np.conj(doubled[:-1]))
    return math.atan2(float(y[0]), float(x[0])) + 0.5 * np.concatenate([[0.0], np.cumsum(turns)])


def precession_rate(turning_points: np.ndarray) -> tuple[float, float]:
    """Swing-plane rate (rad/s, counter-clockwise about up positive) and its standard error, from turning points.

    ψ = atan2(y, x) of each turning point (the frame is x South, y East, z Up, so ψ grows counter-clockwise
    seen from above); consecutive turning points lie at opposite ends of the swing, ψ and ψ + π, so ψ is
    followed modulo π (``unwrapped_azimuth``); the rate is the least-squares slope of ψ against t, computed on centred data, with
    the usual standard error √(Σ residual² / (N − 2) / Σ(t − t̄)²) (e.g. NIST/SEMATECH e-Handbook of
    Statistical Methods, §4.1.4.1; integrators/README.md "Measuring the precession rate"). NaN with fewer than 3
    points.
    """
    points = np.asarray(turning_points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 3:
        return NAN, NAN
    t = points[:, 0]
    azimuth = unwrapped_azimuth(points[:, 1], points[:, 2])
    slope = least_squares_slope(t, azimuth)
    if math.isnan(slope):
        return NAN, NAN
    t_centred = t - t.mean()
    residual = azimuth - azimuth.mean() - slope * t_centred
    stderr = math.sqrt(float(np.dot(residual, residual)) / (t.size - 2) / float(np.dot(t_centred, t_centred)))
    return slope, stderr


def _node_polynomial_maxima(nodes: int) -> tuple[float, float]:
    """max over every window shift and every u in the interval [0, 1] of |W(u)| and |W′(u)|, W(u) = Π (u − u_j)³
    over the window's nodes u_j (grid units): the node factor of the Hermite error f⁽³ⁿ⁾(ξ)·W(u)Δ³ⁿ/(3n)!."""
    u = np.linspace(0.0, 1.0, 2001)
    largest, steepest = 0.0, 0.0
    for shift in range(nodes - 1):
        polynomial = np.polynomial.Polynomial.fromroots(np.repeat(np.arange(nodes) - shift, 3))
        largest = max(largest, float(np.max(np.abs(polynomial(u)))))
        steepest = max(steepest, float(np.max(np.abs(polynomial.deriv()(u)))))
    return largest, steepest


_W_MAX, _W_SLOPE_MAX = _node_polynomial_maxima(HERMITE_NODES)
HERMITE_ORDER = 3 * HERMITE_NODES
"""The local interpolant matches 3·nodes conditions: its error is f⁽¹⁸⁾(ξ)·W(u)Δ¹⁸/18! (Burden & Faires §3.4)."""
HERMITE_ERROR_WEIGHT = _W_MAX / math.factorial(HERMITE_ORDER)
HERMITE_ERROR_SLOPE_WEIGHT = _W_SLOPE_MAX / math.factorial(HERMITE_ORDER)
TIME_ROUNDOFF = 16.0 * np.finfo(np.float64).eps
"""Round-off of a located time relative to the time itself: t is a double (ε·t) and the root is found to a
few ε of the grid interval; 16ε leaves a margin of about 4 over the largest error measured on the scenes."""
AZIMUTH_ROUNDOFF_RAD = 64.0 * np.finfo(np.float64).eps
"""Round-off of a turning point's azimuth: the interpolant's value (a Chebyshev sum of 18 terms) and atan2."""


def turning_time_error_bound(params: PendulumParameters, output_interval_s: float, duration_s: float = 0.0) -> float:
    """Bound (s) on the error of a turning point's time located on the grid (linear model, release at rest),
    up to ``duration_s``.

    The radial part of the Hermite error, ≤ Ω¹⁸AΔ¹⁸|W(u)|/18!, has a slope ≤ Ω¹⁸AΔ¹⁷|W′|/18! that moves the
    maximum of the radius, whose curvature is Ω²A, by δ ≤ |W′|·Ω¹⁶Δ¹⁷/18!; round-off adds ``TIME_ROUNDOFF``·t.
    """
    big_omega = math.hypot(params.pendulum_frequency_rad_s, params.vertical_rate_rad_s)
    interpolation = HERMITE_ERROR_SLOPE_WEIGHT * big_omega ** (HERMITE_ORDER - 2) * output_interval_s ** (HERMITE_ORDER - 1)
    return interpolation + TIME_ROUNDOFF * (duration_s + output_interval_s)


def azimuth_error_bound(params: PendulumParameters, output_interval_s: float, duration_s: float = 0.0) -> float:
    """Bound (rad) on the azimuth error of one turning point located on the grid, linear model, release at rest.

    The exact motion is z = e^{−iat} w with w = A(c₊e^{iΩs} + c₋e^{−iΩs}), c± = (1 ± a/Ω)/2 (``models.analytic``),
    so z⁽ⁿ⁾ = e^{−iat}(d/dt − ia)ⁿ w, n = 18. Three effects move the measured azimuth: (i) the tangential part of
    the interpolation error: |Im (d/dt − ia)ⁿ w| = A|sin Ωs|·|c₊(Ω−a)ⁿ − c₋(Ω+a)ⁿ| ≈ (n − 1)aΩⁿ⁻¹A|sin Ωs|,
    bounded here by (n + 1)aΩⁿ⁻¹A, gives (n + 1)(a/Ω)(ΩΔ)ⁿ|W|/n!; (ii) the time error δ of
    ``turning_time_error_bound``: the azimuth is stationary at a turning point, so the pair (t + δ, ψ) sits a·δ
    off the line ψ₀ − a t; (iii) round-off, ``AZIMUTH_ROUNDOFF_RAD``. The bound is their sum; for small swings of
    the other models it holds to leading order.
    """
    a = abs(params.vertical_rate_rad_s)
    big_omega = math.hypot(params.pendulum_frequency_rad_s, a)
    tangential = ((HERMITE_ORDER + 1) * (a / big_omega) * (big_omega * output_interval_s) ** HERMITE_ORDER
                  * HERMITE_ERROR_WEIGHT)
    return tangential + a * turning_time_error_bound(params, output_interval_s, duration_s) + AZIMUTH_ROUNDOFF_RAD


def rate_error_bound(turning_times_s: np.ndarray, azimuth_error_rad: float) -> float:
    """Worst-case error (rad/s) of the least-squares slope when every azimuth errs by at most ``azimuth_error_rad``.

    The slope is Σ(t − t̄)ψ / Σ(t − t̄)², so errors e_i with |e_i| ≤ ε move it by at most ε Σ|t − t̄| / Σ(t − t̄)²
    (≈ 3ε/T over a span T): a bound that holds for systematic errors too, unlike the standard error.
    """
    t_centred = np.asarray(turning_times_s, dtype=np.float64) - np.mean(turning_times_s)
    return azimuth_error_rad * float(np.sum(np.abs(t_centred))) / float(np.dot(t_centred, t_centred))


def rate_measurement_floor(params: PendulumParameters, output_interval_s: float, duration_s: float) -> float:
    """Worst-case error (rad/s) of a precession rate measured on a grid of spacing ``output_interval_s`` over
    ``duration_s`` from an exact trajectory: ``rate_error_bound`` of ``azimuth_error_bound`` at the turning
    points of a swing released from rest (every half period π/Ω). Below this, a rate error is the measurement's,
    not the integrator's."""
    big_omega = math.hypot(params.pendulum_frequency_rad_s, params.vertical_rate_rad_s)
    times = np.arange(0.0, duration_s, math.pi / big_omega)
    if times.size < 3:
        return NAN
    return rate_error_bound(times, azimuth_error_bound(params, output_interval_s, duration_s))


def released_from_rest(params: PendulumParameters) -> bool:
    """Whether the swing starts at rest, so that t = 0 is itself a turning point (a radius maximum)."""
    return params.release_velocity_m_s == (0.0, 0.0)


def rate_scale(params: PendulumParameters) -> float:
    """Normaliser (rad/s) of precession-rate errors: Ω_E|sin φ|, or Ω_E at the equator (NaN without rotation)."""
    scale = abs(params.vertical_rate_rad_s)
    if scale == 0.0:
        scale = params.earth_rate_rad_s
    return scale if scale > 0.0 else NAN
