"""The adaptive Gragg-Bulirsch-Stoer driver: ODEX's order and step-size control, compiled.

The algorithm is Hairer and Wanner's ODEX (Hairer, Nørsett & Wanner, Solving ODEs I, 2nd ed., §II.9, "Order and
step size control" and "Dense output"; odex.f of 1995/2009, http://www.unige.ch/~hairer/software.html), in numba
with scalars and arrays allocated once per run, on the lines of ``integrators.extrapolation``:

* **Table and error**: line j (n_j substeps, the harmonic sequence 2, 4, 6, …, at most ``MAX_LINES`` = 9 lines,
  ODEX's default ``KM``) is extrapolated in place by Aitken-Neville; its error is the RMS over the components of
  (T_{jj} − T_{j,j−1}) / (atol_i + rtol·max(|y_i|, |T_{jj,i}|)).
* **Step per line**: H_j = H / min(4/f, max(f, (err_j/0.65)^{1/(2j−1)}/0.94)), f = 0.02^{1/(2j−1)}, and the
  work per unit step W_j = A_j / H_j (A_j = 1 + n₁ + … + n_j evaluations).
* **Convergence monitor** (k: the target line): after line k − 1 accept if err ≤ 1, reject if err > (n_{k+1}n_k/4)²;
  after line k accept if err ≤ 1; then compute line k + 1 only if err ≤ (n_{k+1}/2)² and accept if its err ≤ 1,
  else reject. A rejected step restarts with H = H_k at order k (or k − 1 if W_{k−1} < 0.8 W_k). The first step
  and a step that ends on an output time build lines 1 … k and accept at the first j > 1 with err ≤ 1.
* **Order after an accepted step**: ODEX's rule (keep k; lower it if W_{k−1} < 0.8 W_k, raise it if
  W_k < 0.9 W_{k−1}), the new H from H_{k_new}, or H_k·A_{k+1}/A_k when raising.
* **Stability check** (ODEX's ``MSTAB``, ``JSTAB``): in lines 1 and 2, ‖f(z₁) − f(z₀)‖² > 4‖f(z₀)‖² (scaled norms)
  rejects the step and halves H, as do an error that does not decrease from line to line (j > 2), a non-finite
  one, and err·u ≥ 1.
* **Output grid**: the steps land on every output time (an output time is a step's end: a step that would pass
  it, or reach within 1 % of a step of it, is cut to end on it), and the output state is the extrapolated value
  there, of the full order. ODEX's dense output (HNW I, §II.9, Hairer & Ostermann) needs the sequence
  2, 6, 10, 14, … and its own interpolation error control; see integrators/README.md "Gragg-Bulirsch-Stoer
  extrapolation" for the choice. A step rejected after a cut is limited to the output time too.
* **Counters**: every acceleration call is counted (``nfev``); a rejected attempt of any kind counts in
  ``rejected``; more than ``max_steps`` attempts, or a step below 10 ulp of t, fails the run.

The initial step is 0.1/k (ODEX: "H = 1/(norm of f'), usually 1e-1 or 1e-3, is good"; k = √(g/L) sets the
norm here) and the initial target line k = max(2, min(8, ⌊−0.6 log₁₀ rtol + 1.5⌋)), as in ODEX.
"""

from __future__ import annotations

import functools
import math
from typing import Callable

import numpy as np
from numba.np.unsafe.ndarray import to_fixed_tuple

from foucault_bench.integrators.extrapolation import HARMONIC, build_midpoint_line, line_costs, step_numbers
from foucault_bench.integrators.grid_stepping import CODE_OK, STATE_SIZE, attempt_code, cut_step, write_initial_rows
from foucault_bench.models import Model
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import PARAMETER_COUNT

MAX_LINES = 9
"""ODEX's default ``KM``: at most 9 lines (order ≤ 18; the target line k ≤ 8)."""

SAFE1, SAFE2, SAFE3 = 0.65, 0.94, 0.5
FAC1, FAC2, FAC3, FAC4 = 0.02, 4.0, 0.8, 0.9
"""ODEX's default step and order parameters (WORK(3)-WORK(9) of odex.f)."""
STABILITY_LINES = 2
"""ODEX's ``JSTAB``: the stability check runs in lines 1 and 2."""
UROUND = 2.3e-16
"""ODEX's unit round-off."""
ACCEPT, REJECT, RESTART = 0, 1, 2
"""Outcomes of one attempt: accepted, rejected by the error test (retry with H_k), or by a failed check (retry
with half the step and a new f(y))."""


def build_driver(acceleration: Callable, lines: int = MAX_LINES) -> Callable:
    """Compile the driver around the model's ``acceleration(x, y, vx, vy, p) -> (ax, ay)`` (see the module
    docstring); the step numbers and costs are frozen into the machine code."""
    line = build_midpoint_line(acceleration)
    numbers = (0,) + step_numbers(HARMONIC, lines)  # 1-indexed, as in ODEX
    costs = (0,) + line_costs(step_numbers(HARMONIC, lines))
    km = lines

    @jit
    def midex(j, y, dz, h, hmax, table, scal, hh, w, errold, rtol, atol, p):
        """Line j into the table, extrapolated; returns (restart, err, errold)."""
        tx, ty, tvx, tvy, fx, fy, fvx, fvy = line(y[0], y[1], y[2], y[3], dz[2], dz[3], h, numbers[j], p)
        table[j, 0], table[j, 1], table[j, 2], table[j, 3] = tx, ty, tvx, tvy
        if j <= STABILITY_LINES:
            del1 = 0.0
            del2 = 0.0
            f1 = (fx, fy, fvx, fvy)
            for i in range(STATE_SIZE):
                del1 += (dz[i] / scal[i]) ** 2
                del2 += ((f1[i] - dz[i]) / scal[i]) ** 2
            if del2 / max(UROUND, del1) > 4.0:
                return True, 0.0, errold
        if j == 1:
            return False, 0.0, errold
        for level in range(j, 1, -1):
            fac = (numbers[j] / numbers[level - 1]) ** 2 - 1.0
            for i in range(STATE_SIZE):
                table[level - 1, i] = table[level, i] + (table[level, i] - table[level - 1, i]) / fac
        err = 0.0
        for i in range(STATE_SIZE):
            scal[i] = atol[i] + rtol * max(abs(y[i]), abs(table[1, i]))
            err += ((table[1, i] - table[2, i]) / scal[i]) ** 2
        err = math.sqrt(err / STATE_SIZE)
        if not err * UROUND < 1.0 or (j > 2 and err >= errold):
            return True, err, errold
        expo = 1.0 / (2 * j - 1)
        facmin = FAC1 ** expo
        fac = 1.0 / min(FAC2 / facmin, max(facmin, (err / SAFE1) ** expo / SAFE2))
        hh[j] = min(h * fac, hmax)
        w[j] = costs[j] / hh[j]
        return False, err, max(4.0 * err, 1.0)

    @jit
    def driver(y0, parameter_vector, t_out, rtol, atol, h_initial, max_steps, out):
        """Integrate from t = 0 through every time of ``t_out``; returns (code, t reached, nfev, accepted,
        rejected)."""
        p = to_fixed_tuple(parameter_vector, PARAMETER_COUNT)
        n_out = t_out.shape[0]
        hmax = t_out[n_out - 1]
        y = np.empty(STATE_SIZE)
        dz = np.empty(STATE_SIZE)
        scal = np.empty(STATE_SIZE)
        table = np.empty((km + 1, STATE_SIZE))
        hh = np.zeros(km + 1)
        w = np.zeros(km + 1)
        for i in range(STATE_SIZE):
            y[i] = y0[i]
            scal[i] = atol[i] + rtol * abs(y[i])
        next_out = write_initial_rows(y, t_out, out)
        t = 0.0
        h = min(h_initial, 0.5 * hmax)
        k = max(2, min(km - 1, int(-math.log10(rtol + 1e-40) * 0.6 + 1.5)))
        err = 0.0
        errold = 1e10
        reject = False
        nfev = 0
        attempts = 0
        accepted = 0
        rejected = 0
        code = CODE_OK
        while next_out < n_out and code == CODE_OK:
            target = t_out[next_out]
            h, last = cut_step(t, min(h, hmax), target)
            ax, ay = acceleration(y[0], y[1], y[2], y[3], p)
            dz[0], dz[1], dz[2], dz[3] = y[2], y[3], ax, ay
            nfev += 1
            first_or_last = attempts == 0 or last
            while True:
                attempts += 1
                code = attempt_code(t, h, attempts, max_steps)
                if code != CODE_OK:
                    break
                outcome = REJECT
                kc = 0
                hope = False
                if first_or_last:
                    for j in range(1, k + 1):
                        kc = j
                        restart, err, errold = midex(j, y, dz, h, hmax, table, scal, hh, w, errold, rtol, atol, p)
                        nfev += numbers[j]
                        if restart:
                            outcome = RESTART
                            break
                        if j > 1 and err <= 1.0:
                            outcome = ACCEPT
                            break
                    hope = outcome == REJECT
                else:
                    kc = k - 1
                    for j in range(1, k):
                        restart, err, errold = midex(j, y, dz, h, hmax, table, scal, hh, w, errold, rtol, atol, p)
                        nfev += numbers[j]
                        if restart:
                            outcome = RESTART
                            break
                    monitor = outcome != RESTART and not (k == 2 or reject)
                    if monitor and err <= 1.0:
                        outcome = ACCEPT
                    elif outcome != RESTART and not (monitor and err > (numbers[k + 1] * numbers[k] / 4.0) ** 2):
                        restart, err, errold = midex(k, y, dz, h, hmax, table, scal, hh, w, errold, rtol, atol, p)
                        nfev += numbers[k]
                        kc = k
                        if restart:
                            outcome = RESTART
                        elif err <= 1.0:
                            outcome = ACCEPT
                        else:
                            hope = True
                if hope and not err > (numbers[k + 1] / 2.0) ** 2:
                    kc = k + 1
                    restart, err, errold = midex(kc, y, dz, h, hmax, table, scal, hh, w, errold, rtol, atol, p)
                    nfev += numbers[kc]
                    outcome = RESTART if restart else (REJECT if err > 1.0 else ACCEPT)
                if outcome == RESTART:
                    h *= SAFE3
                    reject = True
                    rejected += 1
                    break
                if outcome == REJECT:
                    k = min(k, kc, km - 1)
                    if k > 2 and w[k - 1] < w[k] * FAC3:
                        k -= 1
                    rejected += 1
                    h, last = cut_step(t, hh[k], target)
                    reject = True
                    first_or_last = False
                    continue
                # accepted: the extrapolated value, then ODEX's order and step choice
                t = target if last else t + h
                for i in range(STATE_SIZE):
                    y[i] = table[1, i]
                accepted += 1
                if last:
                    out[next_out, :] = y
                    next_out += 1
                if kc == 2:
                    kopt = min(3, km - 1)
                    if reject:
                        kopt = 2
                elif kc <= k:
                    kopt = kc
                    if w[kc - 1] < w[kc] * FAC3:
                        kopt = kc - 1
                    if w[kc] < w[kc - 1] * FAC4:
                        kopt = min(kc + 1, km - 1)
                else:
                    kopt = kc - 1
                    if kc > 3 and w[kc - 2] < w[kc - 1] * FAC3:
                        kopt = kc - 2
                    if w[kc] < w[kopt] * FAC4:
                        kopt = min(kc, km - 1)
                if reject:
                    k = min(kopt, kc)
                    h = min(h, hh[k])
                    reject = False
                elif kopt <= kc:
                    h = hh[kopt]
                    k = kopt
                else:
                    if kc < k and w[kc] < w[kc - 1] * FAC4:
                        h = hh[kc] * costs[kopt + 1] / costs[kc]
                    else:
                        h = hh[kc] * costs[kopt] / costs[kc]
                    k = kopt
                break
        return code, t, nfev, accepted, rejected

    return driver


@functools.lru_cache(maxsize=None)
def compiled_driver(model: Model) -> Callable:
    """The driver for ``model`` (compiled on first use, cached on disk by numba)."""
    return build_driver(model.numba_acceleration)
