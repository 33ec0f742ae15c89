"""Convergence: the order of accuracy seen in a sweep of step sizes (``observed_order``)."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from foucault_bench.bench.problems.turning_points import least_squares_slope

NAN = math.nan

# --- convergence -------------------------------------------------------------------------------------------------


def observed_order(step_sizes: Sequence[float], errors: Sequence[float], *, max_error: float = 0.1,
                   agreement: float = 0.1, min_slope: float = 0.5, finest: int = 4) -> float:
    """Order of convergence p in error ≈ C hᵖ seen in a sweep: the least-squares slope of log error on log h
    over the longest stretch of the sweep where the error falls at one rate.

    A log-log convergence plot has three regimes (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.1 and
    Fig. 1.3 of §II.4: the straight asymptotic line of slope p between a pre-asymptotic start at large h and a
    round-off floor at small h, where the error stops falling or grows as the steps multiply). The rule,
    documented so that tests, the report and ``check`` agree on it:

    1. drop points whose step or error is not finite and positive, and points with error > ``max_error``
       (default 0.1 of the amplitude or of the rate: the error has saturated); average repeated step sizes
       in log space;
    2. local slopes between neighbouring steps; a *window* is a run of consecutive points whose local slopes
       all lie within ``agreement`` (10 %) of the window's median slope, and that median is at least
       ``min_slope`` (0.5: the error falls as h shrinks; no consistent method has an order below 1).
       Points on a round-off floor (local slopes near zero or negative) and a steep pre-asymptotic start
       (slopes still changing) break windows; a clean sweep is one window;
    3. take the longest window (most points; among equals, the one whose local slopes spread least, then the
       one at the finer steps: a window that reaches into the onset of round-off or into the pre-asymptotic
       start spreads more) and fit its ``finest`` (4) smallest steps, where the higher-order terms have died
       out most.

    Returns NaN when fewer than 2 points remain or no window qualifies. With exactly 2 usable points the
    slope between them is returned if it is at least ``min_slope``. ``observed_order_fit`` also says how many
    points the slope was fitted on.
    """
    return observed_order_fit(step_sizes, errors, max_error=max_error, agreement=agreement, min_slope=min_slope,
                              finest=finest)[0]


def observed_order_fit(step_sizes: Sequence[float], errors: Sequence[float], *, max_error: float = 0.1,
                       agreement: float = 0.1, min_slope: float = 0.5, finest: int = 4) -> tuple[float, int]:
    """``observed_order`` and the number of points its slope was fitted on (distinct step sizes, repeats
    averaged; 0 with the NaN order, e.g. when every error saturated above ``max_error``)."""
    log_h, log_e = _log_points(step_sizes, errors, max_error)
    if log_h.size < 2:
        return NAN, 0
    start, stop = fitted_window(log_h, log_e, agreement=agreement, min_slope=min_slope)
    if stop - start < 2:
        return NAN, 0
    start = max(start, stop - finest)
    return least_squares_slope(log_h[start:stop], log_e[start:stop]), stop - start


def _log_points(step_sizes: Sequence[float], errors: Sequence[float], max_error: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """log h and log error of the usable points, repeated steps averaged, largest step first."""
    h = np.asarray(step_sizes, dtype=np.float64)
    e = np.asarray(errors, dtype=np.float64)
    if h.shape != e.shape:
        raise ValueError("step_sizes and errors must have the same length")
    keep = np.isfinite(h) & (h > 0) & np.isfinite(e) & (e > 0) & (e <= max_error)
    log_h, inverse = np.unique(np.log(h[keep]), return_inverse=True)
    log_e = np.bincount(inverse, weights=np.log(e[keep])) / np.maximum(np.bincount(inverse), 1)
    return log_h[::-1], log_e[::-1]


def fitted_window(log_h: np.ndarray, log_e: np.ndarray, *, agreement: float = 0.1,
                  min_slope: float = 0.5) -> tuple[int, int]:
    """[start, stop) of the points ``observed_order`` fits (points ordered largest step first); (0, 0) when no
    window qualifies. Rule 2-3 of ``observed_order``."""
    local = np.diff(log_e) / np.diff(log_h)  # local[m]: slope between points m and m + 1
    best, best_key = (0, 0), (0, 0.0, 0)
    for first in range(local.size):
        for last in range(local.size, first, -1):  # the longest window starting at ``first``
            slopes = local[first:last]
            median = float(np.median(slopes))
            if median >= min_slope and np.all(np.abs(slopes - median) <= agreement * median):
                key = (last - first + 1, -float(np.ptp(slopes)), first)
                if key > best_key:
                    best, best_key = (first, last + 1), key
                break
    return best
