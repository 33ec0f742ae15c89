"""heyoka's adaptive Taylor integrator, in double (``heyoka_taylor``) and quadruple (``heyoka_taylor_quad``,
the suite's reference) precision.

Method: Taylor series of the solution computed to order p by automatic differentiation of the model's
expressions (``Model.heyoka_taylor_system``: ``Model.heyoka_system`` and a model's step watch, JIT-compiled by LLVM); p = ⌈−½ ln ε + 1⌉ (20 at ε = 2.2e-16, 39 at
1e-33) and the step h from the last two Taylor coefficients so that the truncated remainder is about ε
(Jorba & Zou, Exp. Math. 14, 99 (2005); Biscani & Izzo, MNRAS 504, 2614 (2021)). The order is fixed by the
tolerance, so ``order`` is ``None`` here and the run's order is in ``Solution.extra["taylor_order"]``.

Facts the tables rely on:

* **Counters.** ``steps`` = Taylor steps (from the propagate outcome); ``nfev`` = ``steps``: one Taylor
  expansion per step, which costs about p evaluations' worth of arithmetic, so ``nfev`` is not comparable with
  the right-hand-side counts of Runge-Kutta or multistep methods. ``rejected_steps`` = 0 and ``njev`` = 0:
  the step is chosen a priori from the coefficients (never rejected) and no Jacobian is used.
* **Tolerance.** heyoka's ε = ``tol × min(1, max scale)`` (``integrators.adaptive``: heyoka controls the error
  absolutely while every |y_i| < 1 and relatively above). ``tol`` = machine epsilon reproduces heyoka's default.
* **Stability.** Explicit (no A-stability). The step is set from the Taylor coefficients so that the truncated
  remainder stays near ε, i.e. where the truncated series still reproduces the exact propagator to about ε;
  steps are accuracy-limited (Panthéon, tol = machine epsilon: about 3 steps per swing, kh ≈ 2).
* **Turning points.** A non-terminal event on r·ṙ = xẋ + yẏ with negative direction; the callback reads the
  position at the root from heyoka's dense output. heyoka reports the release point t = 0 as a root for a
  release from rest; ``integrators.adaptive.turning_points`` drops it. heyoka integrates event equations
  together with the system (heyoka docs, "Event detection"), so their Taylor coefficients enter the step-size
  control: r·ṙ oscillates at twice the swing frequency, and with ``monitor=True`` heyoka takes about twice as
  many (and correspondingly more accurate) steps on these models (Panthéon, linear model, 1 h at tol = machine
  epsilon: 2592 steps with events, 1333 without). The benchmark runner and the references therefore call
  with ``monitor=False`` (no event: the same work as every other integrator, the turning points come from the
  output grid, ``bench.problems.turning_points``); ``monitor=True`` is for users who want heyoka's own event
  location (and the tests that compare it with the grid's).
* **Failures.** The iteration limit (``max_steps``, default ``integrators.adaptive.step_budget``) becomes a
  ``failed`` solution and a non-finite state a ``diverged`` one, each with heyoka's outcome in the message.
  heyoka counts iterations against the limit but reports only steps of non-zero size: at a singularity its
  step underflows to zero and it stops at the limit with fewer reported steps (heyoka taylor.cpp,
  ``propagate_until_impl``).

**Compilation cache and reuse.** Building an integrator JIT-compiles it (measured on this 2-core machine with
heyoka's disk cache off, events on: 0.14-1.0 s in double and 0.5-6.6 s in real128 per model, the spherical
model the slowest, the upper figures under load). The compiled integrator for each (model, precision, ε,
events on/off) is built once per process (``_compiled_template``). Each thread copies it once
(``working_integrator``: a copy costs about 1 ms, as much as a whole 300-s solve) and reuses its copy for
every later run with the same key, reset at the start of each run: time, state and parameters set, event
cooldowns reset and the turning-point recorder emptied. A thread-local copy keeps this safe under Dask
workers that run tasks in threads (taylor_adaptive is not safe to propagate from two threads at once), and
the reset makes repeated runs bitwise identical (``tests/test_adaptive.py``). What a run of one problem at one setting
needs besides (heyoka's ε, the step budget, the grid, release state and parameters in heyoka's floating-point
type, views of the integrator's state and parameter buffers) is prepared once and kept for the thread's last
problem (``prepared_run``), so a timed repeat of the same problem does no Python work beyond the reset and the
``Solution``: the adapter costs about 3.5 µs over bare heyoka's reset-and-propagate (``foucault-bench perf
--only adapters``, bench/PERF.md). heyoka 7.13 also keeps compiled
code on disk (``heyoka.llvm_state.get_diskcache_enabled()`` is true by default, directory
``heyoka.llvm_state.get_diskcache_path()``, by default ~/.cache/heyoka, 20 GiB limit): a new process loads
the code in 0.02-0.07 s instead of compiling it.
"""

from __future__ import annotations

import collections
import copy
import functools
import hashlib
import os
import threading
import time
from dataclasses import dataclass
from typing import Any, ClassVar, cast

import numpy as np

from foucault_bench.integrators.adaptive import (
    AdaptiveIntegrator,
    heyoka_tolerance,
    step_budget,
    turning_points,
)
from foucault_bench.integrators.base import COST_COMPILED, STATUS_DIVERGED, STATUS_FAILED, Problem, Solution, StreamedMetrics
from foucault_bench.integrators.registry import register
from foucault_bench.models import Model
from foucault_bench.models.jit import built_once, log_build

REFERENCE_TOLERANCE = 1.0e-33
"""``tol`` of the quadruple-precision reference runs (real128 carries about 34 significant digits)."""


@functools.lru_cache(maxsize=1)
def _outcomes():
    """``heyoka.taylor_outcome`` (imported on first use: importing heyoka costs a worker about 0.7 s)."""
    import heyoka

    return heyoka.taylor_outcome


@functools.lru_cache(maxsize=None)
def _fp_type(precision: str) -> type:
    import heyoka

    return {"double": float, "quad": heyoka.real128}[precision]


class _TurningPointRecorder:
    """Callback of heyoka's non-terminal event r·ṙ = 0: records (t, x, y) at each root from the dense output."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, float, float]] = []

    def __call__(self, integrator, time, d_sign) -> None:
        integrator.update_d_output(time)
        position = integrator.d_output
        self.rows.append((float(time), float(position[0]), float(position[1])))


def _disk_cache_lock(key: str) -> str | None:
    """The lock file, in heyoka's disk cache, of the integrator ``key`` names (None when that cache is off)."""
    import heyoka

    state = heyoka.llvm_state
    if not state.get_diskcache_enabled():
        return None
    folder = state.get_diskcache_path()
    os.makedirs(folder, exist_ok=True)
    return os.path.join(folder, f"foucault-bench.{hashlib.sha256(key.encode()).hexdigest()[:16]}.lock")


@functools.lru_cache(maxsize=64)
def _compiled_template(model: Model, precision: str, heyoka_tol: float, with_events: bool):
    """The JIT-compiled integrator for one (model, precision, ε, events) with a placeholder state; runs copy it.

    Built under a lock per key in heyoka's disk cache (``models.jit.built_once``): processes that need the same
    integrator at once (the test workers) compile it once, the others wait and load heyoka's cached code."""
    key = repr((model.name, precision, heyoka_tol, with_events))
    with built_once(lambda: _disk_cache_lock(key)) as waited_s:
        started_s = time.process_time()
        template = _build_template(model, precision, heyoka_tol, with_events)
        cpu_s = time.process_time() - started_s
    log_build("built", waited_s, cpu_s, cpu_s, f"heyoka.taylor_adaptive {model.name}", key)
    return template


def _build_template(model: Model, precision: str, heyoka_tol: float, with_events: bool):
    import heyoka

    fp_type = _fp_type(precision)
    system = model.heyoka_taylor_system()
    x, y, vx, vy = (variable for variable, _ in system[:4])
    events = []
    if with_events:
        events = [heyoka.nt_event(x * vx + y * vy, _TurningPointRecorder(),
                                  direction=heyoka.event_direction.negative, fp_type=fp_type)]
    return heyoka.taylor_adaptive(
        system,
        np.zeros(len(system), dtype=fp_type),
        tol=fp_type(heyoka_tol),
        fp_type=fp_type,
        pars=np.zeros(model.heyoka_parameter_count, dtype=fp_type),
        nt_events=events,
    )


_NO_STATES = np.empty((0, 4))
_NO_STATES.flags.writeable = False

WORKING_COPIES_PER_THREAD = 64
"""Most compiled integrators a thread keeps for reuse (least recently used dropped first), as the templates."""

_thread_copies = threading.local()


def working_integrator(model: Model, precision: str, heyoka_tol: float, with_events: bool):
    """This thread's own copy of the compiled integrator for the key, made on first use and then reused; the
    caller resets time, state, parameters and events before each run (``HeyokaTaylor._solve``)."""
    copies = getattr(_thread_copies, "by_key", None)
    if copies is None:
        copies = _thread_copies.by_key = collections.OrderedDict()
    key = (model, precision, heyoka_tol, with_events)
    integrator = copies.get(key)
    if integrator is None:
        integrator = copies[key] = copy.copy(_compiled_template(model, precision, heyoka_tol, with_events))
        if len(copies) > WORKING_COPIES_PER_THREAD:
            copies.popitem(last=False)
    copies.move_to_end(key)
    return integrator


@dataclass(frozen=True)
class PreparedRun:
    """What every run of one problem at one setting needs, computed once: the working integrator, heyoka's ε,
    the step budget, and the grid, release state and parameters already in heyoka's floating-point type."""

    problem: Problem
    key: tuple
    integrator: Any
    heyoka_tol: float
    budget: int
    order: int
    fp_zero: Any
    grid: np.ndarray
    starts_late: bool
    state0: np.ndarray
    pars: np.ndarray
    state_view: np.ndarray
    pars_view: np.ndarray


def prepared_run(problem: Problem, precision: str, tol: float, monitor: bool, max_steps: int | None) -> PreparedRun:
    """This thread's ``PreparedRun`` for the problem and setting: the last one again when the same problem
    object is solved at the same setting (a run's timed repeats), else a new one. ``Problem`` is immutable
    and compared by identity, and the record keeps it alive, so an identity match is the same problem."""
    key = (precision, tol, monitor, max_steps)
    last = getattr(_thread_copies, "last_run", None)
    if last is not None and last.problem is problem and last.key == key:
        return last
    fp_type = _fp_type(precision)
    model = problem.model
    heyoka_tol = heyoka_tolerance(problem.params, tol)
    integrator = working_integrator(model, precision, heyoka_tol, monitor)
    grid: np.ndarray = np.asarray(problem.t_out, dtype=fp_type)
    run = _thread_copies.last_run = PreparedRun(
        problem=problem, key=key, integrator=integrator, heyoka_tol=heyoka_tol,
        budget=max_steps or step_budget(problem.params, problem.t_end_s), order=integrator.order,
        fp_zero=fp_type(0.0), grid=grid, starts_late=bool(problem.t_out[0] > 0.0),
        state0=np.asarray(model.taylor_initial_state(problem.initial_state, problem.parameter_vector), dtype=fp_type),
        pars=np.asarray(model.heyoka_parameters(problem.parameter_vector), dtype=fp_type),
        state_view=integrator.state, pars_view=integrator.pars,  # views of the integrator's own buffers
    )
    return run


def rewind(run: PreparedRun) -> None:
    """Puts the run's integrator back at t = 0 with the release state and the problem's parameters."""
    run.integrator.time = run.fp_zero
    run.state_view[:] = run.state0
    run.pars_view[:] = run.pars


def final_state_in_quad(problem: Problem) -> np.ndarray:
    """The state (x, y, ẋ, ẏ) at ``problem.t_end_s`` from heyoka's Taylor method in quadruple precision at
    ``REFERENCE_TOLERANCE``, kept in ``heyoka.real128`` (not rounded to doubles): the reference of the order
    sweep in 34-digit arithmetic (``bench.gate.multiprecision_order``). The compiled integrator is the one of
    the quadruple-precision reference runs (``heyoka_taylor_quad``); ``RuntimeError`` if the propagation stops
    short of the end."""
    run = prepared_run(problem, "quad", REFERENCE_TOLERANCE, False, None)
    rewind(run)
    outcome, *_ = run.integrator.propagate_until(_fp_type("quad")(problem.t_end_s), max_steps=run.budget)
    if outcome != _outcomes().time_limit:
        raise RuntimeError(f"the quadruple-precision run stopped early: heyoka outcome {outcome.name}")
    return np.array(run.state_view[:4], copy=True)


def taylor_solution(problem: Problem, states, steps: int, order: int, heyoka_tol: float, outcome, time_reached,
                    budget: int) -> Solution:
    """The ``Solution`` of one heyoka propagation (also one lane of a batch, ``integrators.batch_heyoka``): the
    grid states reached (NaN after a failure), the counters and the outcome as status and message."""
    y = np.asarray(states, dtype=np.float64)[:, :4]  # a new array: heyoka returns it for this call; the
    # columns after the state are those of the model's step watch (``Model.heyoka_taylor_system``)
    t_out = problem.t_out
    if len(y) < t_out.size:  # the rows reached, fewer after a failure; NaN after
        y = np.vstack([y, np.full((t_out.size - len(y), 4), np.nan)])
    solution = Solution(t=t_out, y=y, nfev=steps, njev=0, steps=steps, rejected_steps=0,
                        extra={"taylor_order": order, "heyoka_tol": heyoka_tol})
    outcomes = _outcomes()
    if outcome != outcomes.time_limit:
        solution.status = STATUS_DIVERGED if outcome == outcomes.err_nf_state else STATUS_FAILED
        solution.message = (f"heyoka outcome {outcome.name} at t = {float(time_reached):.6g} s after "
                            f"{steps} steps of non-zero size (iteration limit {budget})")
    return solution


@register
class HeyokaTaylor(AdaptiveIntegrator):
    """Adaptive Taylor method of heyoka in double precision (order from tol, 20 at machine epsilon).

    Options: ``max_steps`` caps the Taylor steps of one run (default: ``integrators.adaptive.step_budget``);
    reaching it gives a ``failed`` solution.
    """

    name: ClassVar[str] = "heyoka_taylor"
    family: ClassVar[str] = "taylor"
    order: ClassVar[int | None] = None
    precision: ClassVar[str] = "double"
    cost_basis: ClassVar[str] = COST_COMPILED  # LLVM-compiled Taylor steps; one Python call per solve
    silence_native_output: ClassVar[bool] = False  # reports through the propagate outcome, prints nothing
    reports_non_finite_states: ClassVar[bool] = True  # checked after every step: outcome err_nf_state
    reference: ClassVar[str] = (
        "Biscani & Izzo, MNRAS 504, 2614 (2021); Jorba & Zou, Exp. Math. 14, 99 (2005); heyoka 7.13 docs"
    )

    def __init__(self, max_steps: int | None = None) -> None:
        if max_steps is not None and max_steps < 1:
            raise ValueError(f"max_steps must be a positive number of steps, got {max_steps!r}")
        self.max_steps = max_steps

    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        run = prepared_run(problem, self.precision, cast(float, tol), monitor, self.max_steps)
        integrator = run.integrator
        rewind(run)
        if monitor:
            integrator.reset_cooldowns()
            integrator.nt_events[0].callback.rows.clear()
        budget = run.budget

        time_limit = _outcomes().time_limit
        states = _NO_STATES
        outcome, steps = time_limit, 0
        if run.starts_late:  # propagate_grid starts at the integrator's time
            outcome, _, _, steps, _, _ = integrator.propagate_until(run.grid[0], max_steps=budget)
        if outcome == time_limit:
            outcome, _, _, grid_steps, _, states = integrator.propagate_grid(run.grid, max_steps=budget - steps)
            steps += grid_steps
        solution = taylor_solution(problem, states, steps, run.order, run.heyoka_tol, outcome,
                                   integrator.time, budget)
        if monitor:
            recorded = np.array(integrator.nt_events[0].callback.rows, dtype=np.float64).reshape(-1, 3)
            solution.streamed = StreamedMetrics(
                turning_points=turning_points(problem, recorded[:, 0], recorded[:, 1], recorded[:, 2])
            )
        return solution


@register
class HeyokaTaylorQuad(HeyokaTaylor):
    """heyoka's adaptive Taylor method in quadruple precision (IEEE binary128, ~34 digits; order 39 at
    tol = 1e-33, ``REFERENCE_TOLERANCE``): the suite's reference solution, far below any double-precision
    error. Software floating point: measured 100× (linear model) to 470× (spherical) the time per step of
    double precision."""

    name: ClassVar[str] = "heyoka_taylor_quad"
    precision: ClassVar[str] = "quad"

