"""scipy's Brent root finder (``brentq``, scipy/optimize/Zeros/brentq.c) compiled around one function, for the
event location of the compiled embedded Runge-Kutta driver (``integrators.embedded_driver``): the turning points
r·ṙ = 0 on a step's dense output, found as scipy's ``solve_ivp`` finds its events (Brent, Algorithms for
Minimization without Derivatives, 1973, ch. 4).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from foucault_bench.models.jit import jit

EVENT_TOLERANCE = 4.0 * np.finfo(np.float64).eps
"""Brent's absolute and relative tolerance on an event time, scipy's ``solve_event_equation``."""
EVENT_MAX_ITERATIONS = 100


def make_event_time(radial_at: Callable) -> Callable:
    """The compiled root finder of ``radial_at(t, t_old, h, y_old, poly, buffer)`` (r·ṙ on the dense output of the
    step from t_old) in [t_old, t_new]: ``event_time(t_old, t_new, h, y_old, poly, buffer)``."""

    @jit
    def event_time(t_old, t_new, h, y_old, poly, buffer):
        """Root of r·ṙ on the dense output in [t_old, t_new]: scipy's brentq (scipy/optimize/Zeros/brentq.c),
        xtol = rtol = 4ε, at most 100 iterations."""
        xpre, xcur = t_old, t_new
        fpre = radial_at(xpre, t_old, h, y_old, poly, buffer)
        fcur = radial_at(xcur, t_old, h, y_old, poly, buffer)
        if fpre * fcur > 0.0:  # no sign change left after round-off (scipy would raise): the nearer end
            return xpre if abs(fpre) < abs(fcur) else xcur
        if fpre == 0.0:
            return xpre
        if fcur == 0.0:
            return xcur
        xblk, fblk, spre, scur = 0.0, 0.0, 0.0, 0.0
        for _ in range(EVENT_MAX_ITERATIONS):
            if fpre * fcur < 0.0:
                xblk, fblk = xpre, fpre
                spre = scur = xcur - xpre
            if abs(fblk) < abs(fcur):
                xpre, xcur, xblk = xcur, xblk, xcur
                fpre, fcur, fblk = fcur, fblk, fcur
            delta = (EVENT_TOLERANCE + EVENT_TOLERANCE * abs(xcur)) / 2.0
            sbis = (xblk - xcur) / 2.0
            if fcur == 0.0 or abs(sbis) < delta:
                return xcur
            if abs(spre) > delta and abs(fcur) < abs(fpre):
                if xpre == xblk:
                    stry = -fcur * (xcur - xpre) / (fcur - fpre)
                else:
                    dpre = (fpre - fcur) / (xpre - xcur)
                    dblk = (fblk - fcur) / (xblk - xcur)
                    stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
                short = abs(spre) if abs(spre) < 3.0 * abs(sbis) - delta else 3.0 * abs(sbis) - delta
                if 2.0 * abs(stry) < short:
                    spre = scur
                    scur = stry
                else:
                    spre = sbis
                    scur = sbis
            else:
                spre = sbis
                scur = sbis
            xpre, fpre = xcur, fcur
            if abs(scur) > delta:
                xcur += scur
            else:
                xcur += delta if sbis > 0.0 else -delta
            fcur = radial_at(xcur, t_old, h, y_old, poly, buffer)
        return xcur

    return event_time
