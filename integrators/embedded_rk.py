"""One compiled driver for every embedded explicit Runge-Kutta pair given as a ``ButcherTableau``.

The driver reproduces scipy's ``solve_ivp`` with an ``RungeKutta`` method (scipy/integrate/_ivp/rk.py,
common.py, ivp.py) step for step, in numba with scalars and arrays allocated once per run:

* **Initial step** (``select_initial_step``; Hairer, Nørsett & Wanner, Solving ODEs I, §II.4): d₀ = ‖y₀‖,
  d₁ = ‖f₀‖, h₀ = 0.01 d₀/d₁ (10⁻⁶ if either is below 10⁻⁵), one Euler step to get d₂ = ‖f₁ − f₀‖/h₀, and
  h = min(100 h₀, (0.01/max(d₁, d₂))^(1/(q+1))), q the error estimator's order; norms are RMS norms scaled
  by atol + rtol·|y₀|. Two right-hand-side evaluations.
* **Error norm**: RMS of err/(atol + rtol·max(|y|, |y_new|)) with err = h Σ eᵢkᵢ; for a tableau with a second
  error estimate (DOP853) Hairer's combination |h|·‖err₅‖²/√(‖err₅‖² + 0.01‖err₃‖²)/√n (HNW I, §II.10;
  scipy's ``DOP853._estimate_error_norm``).
* **Controller**: accept when the norm is below 1; the next step is h·min(10, 0.9·norm^(−1/(q+1))) (10 for a
  zero norm; at most h right after a rejection), a rejected one h·max(0.2, 0.9·norm^(−1/(q+1))); the step is
  cut to end exactly at the final time; a step below 10 ulp of t fails the run, as in scipy.
* **Stages**: k₁ is f(t + h, y_new) of the previous step (first same as last): s evaluations per attempt.
  Dense output, needed in a step that holds output times or a turning point, costs the tableau's extra stages
  (3 for DOP853), counted in ``nfev`` exactly as scipy counts them.
* **Output and events**: the tableau's dense output on every output time, built as scipy builds it (Q = KᵀP and
  y_old + hQ(x, x², …), ``RkDenseOutput``; or Hairer's nested form, ``Dop853DenseOutput``), and the turning
  points (r·ṙ = xẋ + yẏ crossing from + to −, direction −1 as scipy's event) found on it by scipy's ``brentq``
  iteration with its tolerances 4ε (Brent, Algorithms for Minimization without Derivatives, 1973, ch. 4).
* **Floating point**: every sum is formed in the order numpy's BLAS forms it for scipy: a stage combination
  Σⱼ aᵢⱼkⱼ as OpenBLAS's ``dgemv_n`` (blocks of four terms as two fused multiply-add chains, then a pair, then a
  single term), a matrix product as its small ``dgemm`` (one fused chain in order), the dense polynomial at one
  time as its ``dgemv_t`` ((q₀p₀ + q₂p₂) + (q₁p₁ + q₃p₃)), a norm as ``np.linalg.norm`` (in order, unfused).
  With numpy on OpenBLAS's Haswell or Zen kernel (the PyPI wheels; OpenBLAS takes its SkylakeX kernel, which
  orders the stage sums otherwise, where it detects AVX-512) every step size, accept/reject decision, output
  state and turning point is then bitwise scipy's; with another kernel or BLAS the same algorithm agrees to
  round-off (integrators/README.md "Compiled embedded Runge-Kutta pairs").

``EmbeddedRungeKutta`` is the integrator base: a subclass declares ``tableau`` and its facts and registers.
"""

from __future__ import annotations

import functools
import math
from typing import Any, Callable, ClassVar, cast

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic
from numba.np.unsafe.ndarray import to_fixed_tuple
from scipy.integrate import OdeSolver

from foucault_bench.integrators.adaptive import AdaptiveIntegrator, absolute_tolerance, step_budget, turning_points
from foucault_bench.integrators.base import STATUS_FAILED, Problem, Solution, StreamedMetrics
from foucault_bench.integrators.tableau import ButcherTableau
from foucault_bench.models import Model
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import PARAMETER_COUNT

STATE_SIZE = 4

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
"""scipy's step-size controller constants (scipy/integrate/_ivp/rk.py)."""

EVENT_TOLERANCE = 4.0 * np.finfo(np.float64).eps
"""Brent's absolute and relative tolerance on an event time, scipy's ``solve_event_equation``."""
EVENT_MAX_ITERATIONS = 100

CODE_OK, CODE_TOO_SMALL_STEP, CODE_STEP_LIMIT, CODE_NO_PROGRESS = 0, 1, 2, 3
MESSAGES = {
    CODE_TOO_SMALL_STEP: "Required step size is less than spacing between numbers (scipy's message) at t = {t!r} s",
    CODE_STEP_LIMIT: "step limit of {limit} accepted steps reached at t = {t!r} s",
    CODE_NO_PROGRESS: "no progress: the step size fell to zero at t = {t!r} s",
}


@intrinsic
def fused_multiply_add(typingctx, x, y, z):
    """x·y + z rounded once (LLVM's ``llvm.fma.f64``: the hardware instruction, or libm's ``fma``)."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, sig, args):
        double = ir.DoubleType()
        function = builder.module.declare_intrinsic("llvm.fma", [double], ir.FunctionType(double, [double] * 3))
        return builder.call(function, args)

    return signature, codegen


@jit(inline="always")
def _combine(k, weights, n_terms, component):
    """Σⱼ<n weightsⱼ·k[j, component] in the order of OpenBLAS's dgemv_n (see the module docstring)."""
    total = 0.0
    j = 0
    for _ in range(n_terms // 4):
        even = k[j, component] * weights[j]
        odd = k[j + 1, component] * weights[j + 1]
        even = fused_multiply_add(k[j + 2, component], weights[j + 2], even)
        odd = fused_multiply_add(k[j + 3, component], weights[j + 3], odd)
        total = total + (even + odd)
        j += 4
    if n_terms % 4 >= 2:
        total = total + (k[j, component] * weights[j] + k[j + 1, component] * weights[j + 1])
        j += 2
    if n_terms % 2 == 1:
        total = total + k[j, component] * weights[j]
    return total


@jit(inline="always")
def _larger(a, b):
    """np.maximum: the larger value, NaN if either is NaN."""
    if a != a or b != b:
        return math.nan
    return a if a >= b else b


def build_driver(acceleration: Callable, a: np.ndarray, b: np.ndarray, e: np.ndarray, e_low: np.ndarray,
                 has_low: bool, dense: np.ndarray, hairer: bool, stages: int, extra: int, exponent: float,
                 estimator_order: int) -> Callable:
    """Compile the driver around the model's ``acceleration(x, y, vx, vy, p) -> (ax, ay)`` for one tableau, whose
    coefficients numba freezes into the machine code as constants. ``dense`` is P (rows × degree) or, with
    ``hairer``, Hairer's D (rows F₃… over the stages)."""
    n_rows = stages + 1 + extra
    n_poly = 3 + dense.shape[0] if hairer else dense.shape[1]

    @jit(inline="always")
    def rhs(state, out, row, p):
        ax, ay = acceleration(state[0], state[1], state[2], state[3], p)
        out[row, 0] = state[2]
        out[row, 1] = state[3]
        out[row, 2] = ax
        out[row, 3] = ay

    @jit(inline="always")
    def prepare_dense(h, y_old, y_new, k, poly):
        """The step's polynomial, as scipy builds its dense output: Q = Kᵀ·P (``RkDenseOutput``) or Hairer's
        F₀…F₆ (``Dop853DenseOutput``), matrix products summed as OpenBLAS's small dgemm does (in order, fused)."""
        if hairer:
            for i in range(STATE_SIZE):
                delta = y_new[i] - y_old[i]
                poly[0, i] = delta
                poly[1, i] = h * k[0, i] - delta
                poly[2, i] = 2.0 * delta - h * (k[stages, i] + k[0, i])
                for r in range(dense.shape[0]):
                    total = 0.0
                    for j in range(n_rows):
                        total = fused_multiply_add(dense[r, j], k[j, i], total)
                    poly[3 + r, i] = h * total
        else:
            for m in range(dense.shape[1]):
                for i in range(STATE_SIZE):
                    total = 0.0
                    for j in range(n_rows):
                        total = fused_multiply_add(k[j, i], dense[j, m], total)
                    poly[m, i] = total

    @jit(inline="always")
    def dense_state(x, h, y_old, poly, single, out):
        """y(t_old + xh) into ``out``, in scipy's arithmetic: Hairer's nested form, or y_old + h·Q·(x, x², …) with
        the product summed as numpy's BLAS sums a matrix times one vector (``single``: one output time or an
        event, 4 terms as (q₀p₀ + q₂p₂) + (q₁p₁ + q₃p₃)) or times a matrix (several output times: in order, fused)."""
        if hairer:
            for i in range(STATE_SIZE):
                value = 0.0
                for index in range(n_poly):
                    value += poly[n_poly - 1 - index, i]
                    value *= x if index % 2 == 0 else 1.0 - x
                out[i] = value + y_old[i]
        else:
            p0 = x
            p1 = p0 * x
            p2 = p1 * x
            p3 = p2 * x
            for i in range(STATE_SIZE):
                if single and n_poly == 4:
                    total = (poly[0, i] * p0 + poly[2, i] * p2) + (poly[1, i] * p1 + poly[3, i] * p3)
                else:
                    total = 0.0
                    power = 1.0
                    for m in range(n_poly):
                        power = power * x
                        total = fused_multiply_add(poly[m, i], power, total)
                out[i] = h * total + y_old[i]

    @jit(inline="always")
    def radial_at(t, t_old, h, y_old, poly, buffer):
        dense_state((t - t_old) / h, h, y_old, poly, True, buffer)
        return buffer[0] * buffer[2] + buffer[1] * buffer[3]

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

    @jit
    def rms_norm_scaled(values, scale):
        total = 0.0
        for i in range(STATE_SIZE):
            x = values[i] / scale[i]
            total = total + x * x
        return math.sqrt(total) / 2.0  # / √n, n = 4

    @jit
    def driver(y0, parameter_vector, t_out, rtol, atol, max_steps, monitor, out, events, k):
        """Integrate from t = 0 to t_out[-1]; returns (code, t reached, nfev, accepted, rejected, events found)."""
        p = to_fixed_tuple(parameter_vector, PARAMETER_COUNT)
        n_out = t_out.shape[0]
        t_bound = t_out[n_out - 1]
        y = np.empty(STATE_SIZE)
        y_new = np.empty(STATE_SIZE)
        stage_y = np.empty(STATE_SIZE)
        scale = np.empty(STATE_SIZE)
        err = np.empty(STATE_SIZE)
        err_low = np.empty(STATE_SIZE)
        f1 = np.empty((1, STATE_SIZE))
        poly = np.empty((n_poly, STATE_SIZE))
        buffer = np.empty(STATE_SIZE)
        for i in range(STATE_SIZE):
            y[i] = y0[i]
        t = 0.0
        rhs(y, k, 0, p)
        nfev = 1
        # select_initial_step
        for i in range(STATE_SIZE):
            scale[i] = atol[i] + abs(y[i]) * rtol
        d0 = rms_norm_scaled(y, scale)
        for i in range(STATE_SIZE):
            err[i] = k[0, i]
        d1 = rms_norm_scaled(err, scale)
        if d0 < 1e-5 or d1 < 1e-5:
            h0 = 1e-6
        else:
            h0 = 0.01 * d0 / d1
        if t_bound < h0:
            h0 = t_bound
        for i in range(STATE_SIZE):
            stage_y[i] = y[i] + h0 * k[0, i]
        rhs(stage_y, f1, 0, p)
        nfev += 1
        for i in range(STATE_SIZE):
            err[i] = f1[0, i] - k[0, i]
        d2 = rms_norm_scaled(err, scale) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / (d2 if d2 > d1 else d1)) ** (1.0 / (estimator_order + 1))
        h_abs = 100.0 * h0
        if h1 < h_abs:
            h_abs = h1
        if t_bound < h_abs:
            h_abs = t_bound

        accepted = 0
        rejected = 0
        n_events = 0
        next_out = 0
        radial = y[0] * y[2] + y[1] * y[3]
        code = CODE_OK
        while True:
            min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
            if h_abs < min_step:
                h_abs = min_step
            step_rejected = False
            while True:
                if h_abs < min_step:
                    code = CODE_TOO_SMALL_STEP
                    break
                t_new = t + h_abs
                if t_new - t_bound > 0.0:
                    t_new = t_bound
                h = t_new - t
                h_abs = abs(h)
                for st in range(1, stages):
                    for i in range(STATE_SIZE):
                        stage_y[i] = y[i] + _combine(k, a[st], st, i) * h
                    rhs(stage_y, k, st, p)
                for i in range(STATE_SIZE):
                    y_new[i] = y[i] + h * _combine(k, b, stages, i)
                rhs(y_new, k, stages, p)
                nfev += stages
                for i in range(STATE_SIZE):
                    scale[i] = atol[i] + _larger(abs(y[i]), abs(y_new[i])) * rtol
                if has_low:
                    for i in range(STATE_SIZE):
                        err[i] = _combine(k, e, stages + 1, i)
                        err_low[i] = _combine(k, e_low, stages + 1, i)
                    norm_high = rms_norm_scaled(err, scale) * 2.0
                    norm_low = rms_norm_scaled(err_low, scale) * 2.0
                    high2 = norm_high * norm_high
                    low2 = norm_low * norm_low
                    if high2 == 0.0 and low2 == 0.0:
                        error_norm = 0.0
                    else:
                        error_norm = abs(h) * high2 / math.sqrt((high2 + 0.01 * low2) * STATE_SIZE)
                else:
                    for i in range(STATE_SIZE):
                        err[i] = _combine(k, e, stages + 1, i) * h
                    error_norm = rms_norm_scaled(err, scale)
                if error_norm < 1.0:
                    if error_norm == 0.0:
                        factor = MAX_FACTOR
                    else:
                        factor = SAFETY * error_norm ** exponent
                        if not factor < MAX_FACTOR:
                            factor = MAX_FACTOR
                    if step_rejected and not factor < 1.0:
                        factor = 1.0
                    h_abs *= factor
                    break
                factor = SAFETY * error_norm ** exponent
                if not factor > MIN_FACTOR:
                    factor = MIN_FACTOR
                h_abs *= factor
                step_rejected = True
                rejected += 1
            if code != CODE_OK:
                break
            accepted += 1
            t_old = t
            t = t_new
            finished = t - t_bound >= 0.0
            if t == t_old:
                code = CODE_NO_PROGRESS
                break
            if not finished and accepted >= max_steps:
                code = CODE_STEP_LIMIT
                break
            # dense output: extra stages once per step that needs it (y still holds y_old)
            event_here = False
            if monitor:
                radial_new = y_new[0] * y_new[2] + y_new[1] * y_new[3]
                event_here = radial >= 0.0 and radial_new <= 0.0
                radial = radial_new
            needs_dense = event_here or (next_out < n_out and t_out[next_out] <= t)
            if needs_dense and extra > 0:
                for st in range(stages + 1, n_rows):
                    for i in range(STATE_SIZE):
                        stage_y[i] = y[i] + _combine(k, a[st], st, i) * h
                    rhs(stage_y, k, st, p)
                nfev += extra
            if needs_dense:
                prepare_dense(h, y, y_new, k, poly)
            if event_here and n_events < events.shape[0]:
                te = event_time(t_old, t, h, y, poly, buffer)
                dense_state((te - t_old) / h, h, y, poly, True, buffer)
                events[n_events, 0] = te
                events[n_events, 1] = buffer[0]
                events[n_events, 2] = buffer[1]
                n_events += 1
            last_out = next_out
            while last_out < n_out and t_out[last_out] <= t:
                last_out += 1
            single = last_out - next_out == 1
            while next_out < last_out:
                dense_state((t_out[next_out] - t_old) / h, h, y, poly, single, buffer)
                for i in range(STATE_SIZE):
                    out[next_out, i] = buffer[i]
                next_out += 1
            for i in range(STATE_SIZE):
                y[i] = y_new[i]
                k[0, i] = k[stages, i]
            if finished:
                break
        return code, t, nfev, accepted, rejected, n_events

    return driver


@functools.lru_cache(maxsize=None)
def compiled_driver(model: Model, tableau: ButcherTableau) -> Callable:
    """The driver for ``model`` and ``tableau`` (compiled on first use, cached on disk by numba)."""
    low = tableau.secondary_error_weights
    hairer = tableau.dense_hairer is not None
    dense = np.asarray(tableau.dense_hairer, dtype=np.float64) if hairer else tableau.dense_matrix()
    return build_driver(model.numba_acceleration, np.ascontiguousarray(tableau.extended_a()),
                        np.asarray(tableau.b, dtype=np.float64), np.asarray(tableau.error_weights, dtype=np.float64),
                        np.asarray(low if low is not None else tableau.error_weights, dtype=np.float64),
                        low is not None, np.ascontiguousarray(dense), hairer, tableau.stages,
                        tableau.extra_stages, -1.0 / (tableau.error_estimator_order + 1),
                        tableau.error_estimator_order)


def scipy_twin_problems(tableau: ButcherTableau, solver: Any) -> list[str]:
    """How ``tableau`` differs from scipy's ``solver`` (none when it is scipy's pair): stage count, orders, and
    the nodes, coefficients and weights c, A, b to within a few units of round-off."""
    problems = [f"{what} {mine} against scipy's {theirs}" for what, mine, theirs in (
        ("stages", tableau.stages, solver.n_stages), ("order", tableau.order, solver.order),
        ("error estimator order", tableau.error_estimator_order, solver.error_estimator_order)) if mine != theirs]
    if problems:
        return problems
    a = np.asarray(tableau.a, dtype=np.float64).reshape(tableau.stages, tableau.stages)[:, : solver.A.shape[1]]
    for what, mine, theirs in (("c", np.asarray(tableau.c), solver.C), ("A", a, solver.A),
                               ("b", np.asarray(tableau.b), solver.B)):
        if not np.allclose(mine, theirs, rtol=0.0, atol=4 * np.finfo(np.float64).eps):
            problems.append(f"{what} differs from scipy's")
    return problems


class EmbeddedRungeKutta(AdaptiveIntegrator):
    """Base of the compiled embedded Runge-Kutta integrators: a subclass declares ``tableau`` (its ``order``
    follows from it) and the usual facts.

    Options: ``max_steps`` caps the accepted steps of one run (default ``integrators.adaptive.step_budget``);
    reaching it gives a ``failed`` solution, as for scipy's integrators.
    """

    tableau: ClassVar[ButcherTableau]
    family: ClassVar[str] = "runge-kutta"
    cost_basis: ClassVar[str] = "compiled"
    steps_of: ClassVar[type[OdeSolver] | None] = None
    """scipy's ``RungeKutta`` solver whose steps this integrator takes (same tableau, error norm, controller and
    initial step: the tests compare them step for step with the registered integrator of that solver), or
    None. Checked when the class is made (``scipy_twin_problems``)."""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "tableau" in cls.__dict__:
            if not (cls.tableau.is_embedded and cls.tableau.has_dense_output):
                raise TypeError(f"{cls.__name__}: the adaptive driver needs a tableau with error weights and a "
                                f"dense output ({cls.tableau.name!r} has {'no error weights' if not cls.tableau.is_embedded else 'no dense output'}; "
                                "a plain tableau is stepped by integrators.explicit_rk.ExplicitRungeKutta)")
            cls.order = cls.tableau.order
        twin = cls.__dict__.get("steps_of")
        if twin is not None:
            problems = scipy_twin_problems(cls.tableau, twin)
            if problems:
                raise TypeError(f"{cls.__name__}.steps_of = {twin.__name__}: " + "; ".join(problems))

    def __init__(self, max_steps: int | None = None) -> None:
        if max_steps is not None and max_steps < 1:
            raise ValueError(f"max_steps must be a positive number of steps, got {max_steps!r}")
        self.max_steps = max_steps

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        limit = self.step_limit(problem)
        out = np.full((problem.t_out.size, STATE_SIZE), np.nan)
        events = np.empty((self.event_capacity(problem) if monitor else 0, 3))
        code, t_reached, nfev, steps, rejected, n_events = compiled_driver(problem.model, self.tableau)(
            problem.initial_state, problem.parameter_vector, problem.t_out, float(cast(float, tol)),
            absolute_tolerance(problem.params, cast(float, tol)), limit, monitor, out, events, self.stage_buffer(),
        )
        return self.driver_solution(problem, out, limit, int(code), float(t_reached), int(nfev), int(steps),
                                    int(rejected), events[:n_events] if monitor else None)

    def step_limit(self, problem: Problem) -> int:
        """Most accepted steps of a run: ``max_steps`` or ``integrators.adaptive.step_budget``."""
        return self.max_steps or step_budget(problem.params, problem.t_end_s)

    @staticmethod
    def event_capacity(problem: Problem) -> int:
        """Rows of the turning-point buffer: 2.2 per small-swing period (a swing has 2) and 16 more."""
        return int(2.2 * problem.t_end_s / problem.params.small_swing_period_s) + 16

    def stage_buffer(self) -> np.ndarray:
        """The driver's stage array (the stages, the first-same-as-last one and the dense output's extras)."""
        return np.empty((self.tableau.stages + 1 + self.tableau.extra_stages, STATE_SIZE))

    @staticmethod
    def driver_solution(problem: Problem, out: np.ndarray, limit: int, code: int, t_reached: float, nfev: int,
                        steps: int, rejected: int, events: np.ndarray | None) -> Solution:
        """The ``Solution`` of one driver run from what it wrote and returned (``events``: the turning points
        found, ``None`` without ``monitor``)."""
        solution = Solution(t=problem.t_out, y=out, nfev=nfev, njev=0, steps=steps, rejected_steps=rejected)
        if code != CODE_OK:
            solution.status = STATUS_FAILED
            solution.message = MESSAGES[code].format(limit=limit, t=t_reached)
        if events is not None:
            solution.streamed = StreamedMetrics(turning_points=turning_points(
                problem, events[:, 0], events[:, 1], events[:, 2]))
        return solution


def scipy_twins() -> dict[str, str]:
    """Registered compiled pair → the registered scipy integrator whose solver it takes the steps of
    (``EmbeddedRungeKutta.steps_of`` against ``ScipyIvpIntegrator.solver_class``), in name order; a pair whose
    solver no registered integrator drives is left out."""
    from foucault_bench.integrators.registry import REGISTRY

    by_solver = {solver: name for name, integrator in REGISTRY.items()
                 if (solver := getattr(integrator, "solver_class", None)) is not None}
    return {name: by_solver[integrator.steps_of] for name, integrator in sorted(REGISTRY.items())
            if isinstance(integrator, EmbeddedRungeKutta) and integrator.steps_of in by_solver}

