"""Convergence: the order of accuracy seen in a sweep of step sizes (``observed_order``)."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from foucault_bench.bench.verdicts.turning_points import least_squares_slope

NAN = math.nan

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
