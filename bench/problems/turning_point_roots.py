"""The roots of r·ṙ on the turning points' local interpolants (``bench.problems.turning_points``): Chandrupatla's
bracketing method as ``scipy.optimize.elementwise.find_root`` runs it (scipy/optimize/_chandrupatla.py, default
tolerances), compiled, one window at a time.

Why not scipy's own: its elementwise loop costs about 0.4 ms of array bookkeeping per iteration, and the roots of a
run's 400-1000 turning points take some 17 iterations: 7-10 ms per run, more than half of a run's verdicts, some
25 s of CPU in the default matrix. Here every operation on a window's numbers is scipy's, in scipy's order (the
Chebyshev sums are numpy's ``chebval``, Clenshaw's recurrence), so the roots are scipy's bit for bit;
``tests/test_verdicts.py`` checks that against scipy on the windows of real runs.

Chandrupatla, "A new hybrid quadratic/bisection algorithm for finding the zero of a nonlinear function without
using derivatives", Advances in Engineering Software 28 (1997) 145-149.
"""

from __future__ import annotations

import math

import numpy as np

from foucault_bench.models.jit import jit

_FINFO = np.finfo(np.float64)
X_ABSOLUTE_TOLERANCE = 4.0 * float(_FINFO.smallest_normal)
"""scipy's default ``xatol``: 4 × the smallest normal double."""
X_RELATIVE_TOLERANCE = 4.0 * float(_FINFO.eps)
"""scipy's default ``xrtol``: 4ε."""
F_ABSOLUTE_TOLERANCE = float(_FINFO.smallest_normal)
"""scipy's default ``fatol``: the smallest normal double (``frtol`` is 0)."""
MAX_ITERATIONS = math.log2(float(_FINFO.max)) - math.log2(float(_FINFO.smallest_normal))
"""scipy's default ``maxiter``: every bisection the normal doubles allow (2046)."""


@jit
def _sign(value):
    """``np.sign``: −1, 0 or 1, NaN for NaN."""
    if value > 0.0:
        return 1.0
    if value < 0.0:
        return -1.0
    if value == 0.0:
        return 0.0
    return math.nan


@jit
def _chebval(coefficients, window, axis, x):
    """``numpy.polynomial.chebyshev.chebval(x, coefficients[:, window, axis])`` (Clenshaw), in numpy's order."""
    n = coefficients.shape[0]
    if n == 1:
        return coefficients[0, window, axis] + 0.0 * x
    if n == 2:
        return coefficients[0, window, axis] + coefficients[1, window, axis] * x
    x2 = 2.0 * x
    c0 = coefficients[n - 2, window, axis]
    c1 = coefficients[n - 1, window, axis]
    for i in range(3, n + 1):
        previous = c0
        c0 = coefficients[n - i, window, axis] - c1
        c1 = previous + c1 * x2
    return c0 + c1 * x


@jit
def _radial_velocity(coefficients, derivative, centre, half_width, window, offset):
    """r·dr/dx of one window's interpolant at one offset (the sign and the root of r·ṙ)."""
    x = (offset - centre) / half_width
    return (_chebval(coefficients, window, 0, x) * _chebval(derivative, window, 0, x)
            + _chebval(coefficients, window, 1, x) * _chebval(derivative, window, 1, x))


@jit
def _best_and_stop(x1, f1, x2, f2, frtol):
    """scipy's ``check_termination``: the end where |f| is smaller (NaN once the bracket is lost), whether to stop,
    and the bracket's width and tolerance."""
    if abs(f1) < abs(f2):
        xmin, fmin = x1, f1
    else:
        xmin, fmin = x2, f2
    stop = False
    if abs(fmin) <= F_ABSOLUTE_TOLERANCE + frtol:
        stop = True
    if _sign(f1) == _sign(f2) and not stop:  # no bracket left
        xmin, fmin, stop = math.nan, math.nan, True
    if (not (math.isfinite(x1) and math.isfinite(x2)) or (math.isnan(f1) and math.isnan(f2))) and not stop:
        xmin, fmin, stop = math.nan, math.nan, True
    width = abs(x2 - x1)
    tolerance = abs(xmin) * X_RELATIVE_TOLERANCE + X_ABSOLUTE_TOLERANCE
    if width < tolerance:
        stop = True
    return xmin, stop, width, tolerance


@jit
def radial_velocity_roots(coefficients, derivative, centre, half_width):
    """The root in offset ∈ [0, 1] of r·ṙ of each window's interpolant (``coefficients``, ``derivative``: Chebyshev
    series (terms, windows, 2) of the position and its derivative), as ``find_root`` returns it in ``res.x`` from the
    bracket (0, 1) (NaN where the ends do not bracket a root)."""
    windows = coefficients.shape[1]
    roots = np.empty(windows)
    for window in range(windows):
        x1, x2 = 0.0, 1.0
        f1 = _radial_velocity(coefficients, derivative, centre, half_width, window, x1)
        f2 = _radial_velocity(coefficients, derivative, centre, half_width, window, x2)
        smaller = math.nan if math.isnan(f1) or math.isnan(f2) else min(abs(f1), abs(f2))
        frtol = 0.0 * smaller
        xmin, stop, width, tolerance = _best_and_stop(x1, f1, x2, f2, frtol)
        t = 0.5
        iterations = 0
        while not stop and iterations < MAX_ITERATIONS:
            x = x1 + t * (x2 - x1)
            f = _radial_velocity(coefficients, derivative, centre, half_width, window, x)
            x3, f3 = x2, f2
            if _sign(f) == _sign(f1):
                x3, f3 = x1, f1
            else:
                x2, f2 = x1, f1
            x1, f1 = x, f
            iterations += 1
            xmin, stop, width, tolerance = _best_and_stop(x1, f1, x2, f2, frtol)
            if stop:
                break
            # inverse quadratic interpolation where it is safe, bisection otherwise (Chandrupatla's eq. 1)
            xi1 = (x1 - x2) / (x3 - x2)
            phi1 = (f1 - f2) / (f3 - f2)
            alpha = (x3 - x1) / (x2 - x1)
            if (1.0 - np.sqrt(1.0 - xi1)) < phi1 and phi1 < np.sqrt(xi1):
                t = f1 / (f1 - f2) * f3 / (f3 - f2) - alpha * f1 / (f3 - f1) * f2 / (f2 - f3)
            else:
                t = 0.5
            shortest = 0.5 * tolerance / width  # keep away from the bracket's ends (np.clip, NaN kept)
            if t < shortest:
                t = shortest
            if t > 1.0 - shortest:
                t = 1.0 - shortest
        roots[window] = xmin
    return roots
