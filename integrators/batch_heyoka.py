"""heyoka's batch mode for many members of one configuration (``integrators.batch``): ``taylor_adaptive_batch``.

heyoka compiles the Taylor integrator for ``heyoka.recommended_simd_size()`` lanes (8 with AVX-512, 4 with
AVX2) and advances all lanes with one call of the compiled step, in SIMD registers (heyoka docs, "Batch mode
overview"; Biscani & Izzo, MNRAS 504, 2614 (2021), §4). Members go into lanes in their order, grouped by
heyoka's ε (``integrators.adaptive.heyoka_tolerance``: one ε per compiled batch integrator, equal for members
with the same release energy); a last, partly filled group repeats its last member in the spare lanes.

**Steps.** Each lane keeps its own time and step size, chosen from its own Taylor coefficients, so a member's
step count is its own, not the batch's: batching does not make members step together (contrast diffrax, whose
vmapped solves take every member's steps together, diffrax issue #692). The Taylor order is the batch's, from
ε, the same as one by one. Measured against one-by-one runs (``tests/test_batch.py``): equal step counts, states
equal to round-off (SIMD versions of the elementary functions round differently from the scalar libm calls).

**Limits.** Double precision only: heyoka 7.13 has no batch mode in real128 (``taylor_adaptive_batch`` takes
``float`` and ``double``), so the quadruple-precision references run member by member. No event detection:
``monitor=True`` runs member by member through the scalar adapter. The step budget of a group is its
smallest member's (``integrators.adaptive.step_budget``). One compiled batch integrator per (model, ε) and
thread, copied from a per-process template and reset before each group, as the scalar adapter does.
"""

from __future__ import annotations

import copy
import functools
import threading
from typing import Sequence, cast

import numpy as np

from foucault_bench.integrators.adaptive import heyoka_tolerance, step_budget
from foucault_bench.integrators.base import Problem, Solution
from foucault_bench.integrators.methods.heyoka_taylor import HeyokaTaylor, taylor_solution
from foucault_bench.models import Model


@functools.lru_cache(maxsize=1)
def lanes() -> int:
    """SIMD lanes of one batch integrator: ``heyoka.recommended_simd_size()``."""
    import heyoka

    return int(heyoka.recommended_simd_size())


@functools.lru_cache(maxsize=32)
def _batch_template(model: Model, heyoka_tol: float, batch_size: int):
    """The JIT-compiled batch integrator for one (model, ε, lanes), placeholder state; each thread copies it."""
    import heyoka

    system = model.heyoka_taylor_system()
    return heyoka.taylor_adaptive_batch(system, np.zeros((len(system), batch_size)), tol=heyoka_tol,
                                        pars=np.zeros((model.heyoka_parameter_count, batch_size)))


_thread_copies = threading.local()


def working_batch_integrator(model: Model, heyoka_tol: float, batch_size: int):
    """This thread's copy of the batch integrator for the key (made on first use, then reused)."""
    copies = getattr(_thread_copies, "by_key", None)
    if copies is None:
        copies = _thread_copies.by_key = {}
    key = (model, heyoka_tol, batch_size)
    if key not in copies:
        copies[key] = copy.copy(_batch_template(model, heyoka_tol, batch_size))
    return copies[key]


def lane_groups(problems: Sequence[Problem], tol: float, batch_size: int) -> list[tuple[float, list[int]]]:
    """Members (indices) in groups of at most ``batch_size`` with one heyoka ε each, in the members' order."""
    by_tol: dict[float, list[int]] = {}
    for index, problem in enumerate(problems):
        by_tol.setdefault(heyoka_tolerance(problem.params, tol), []).append(index)
    return [(heyoka_tol, members[first: first + batch_size]) for heyoka_tol, members in by_tol.items()
            for first in range(0, len(members), batch_size)]


def heyoka_batch_runs(integrator: HeyokaTaylor, problems: Sequence[Problem], steps: Sequence[float | None],
                      tol: float | None, monitor: bool) -> list[Solution]:
    """One ``Solution`` per member (before ``Integrator.finish``), the members propagated in SIMD lanes."""
    batch_size = lanes()
    model = problems[0].model
    t_out = problems[0].t_out
    solutions: list[Solution | None] = [None] * len(problems)
    for heyoka_tol, members in lane_groups(problems, cast(float, tol), batch_size):
        filled = members + [members[-1]] * (batch_size - len(members))
        group = [problems[index] for index in filled]
        budget = integrator.max_steps or min(step_budget(problem.params, problem.t_end_s) for problem in group)
        batch = working_batch_integrator(model, heyoka_tol, batch_size)
        batch.set_time(np.zeros(batch_size))
        batch.state[:] = np.array([model.taylor_initial_state(problem.initial_state, problem.parameter_vector)
                                   for problem in group]).T
        batch.pars[:] = np.array([model.heyoka_parameters(problem.parameter_vector) for problem in group]).T
        taken = np.zeros(batch_size, dtype=np.int64)
        if t_out[0] > 0.0:  # propagate_grid starts at the integrator's time
            batch.propagate_until(np.full(batch_size, t_out[0]), max_steps=budget)
            taken += [result[3] for result in batch.propagate_res]
        _, states = batch.propagate_grid(np.ascontiguousarray(np.repeat(t_out[:, None], batch_size, axis=1)),
                                         max_steps=budget)
        for lane, index in enumerate(members):
            outcome, _, _, lane_steps = batch.propagate_res[lane]
            solutions[index] = taylor_solution(problems[index], np.array(states[:, :, lane]),
                                               int(taken[lane] + lane_steps), batch.order, heyoka_tol,
                                               outcome, batch.time[lane], budget)
    return cast(list[Solution], solutions)
