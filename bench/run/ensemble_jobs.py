"""The members of one ensemble configuration run as one batch: one timed call, one row per member.

An ensemble's members (``bench.problems.ensemble``) that share an integrator and a setting are one configuration
(``configurations``: keyed by ensemble, integrator and the setting asked for). The runner (``bench.run.runner``)
hands each configuration to a worker as one task, ``run_members``, which returns one row per member, in the
members' order, each with the member's own reference and verdicts:

* **One batch.** ``integrators.batch.solve_batch`` runs every member in one call (a compiled loop over the
  members for the fixed-step schemes and the compiled Runge-Kutta pairs, heyoka's SIMD batch mode for
  ``heyoka_taylor``, member by member inside the call for CVODE and scipy). That call is timed as one run by
  the protocol of ``bench.run.timing``: a warm-up over the members' first output interval, then timed repeats
  of the whole batch under the matrix's ``[timing]`` policy (its ``max_total_s`` caps the batch's repeats, not
  each member's). The first repeat's solutions are the members' results; integrators that stream per-step
  metrics make one untimed ``monitor=True`` batch call, as a run alone does (unless the matrix says
  ``step_energy = false``).
* **Cost shares.** A member's cost columns are its batch's divided by the batch's members (``share_columns``):
  ``cpu_time_s``, ``wall_time_s``, their spreads, the repeats' CPU times and ``compile_time_s``; the relative
  precision ``cpu_time_ci95_rel``, ``repeats`` and the machine calibration are the batch's. ``batch_members``
  holds the divisor, so a reader knows the cost is a share (NULL for a run timed alone). Equal shares: what one
  member costs when the ensemble is run, not what it costs alone (members that take more steps, adaptive ones,
  cost more alone; ``nfev`` and ``steps`` stay each member's own).
* **Results.** Each member's solution is the one it gets alone: bitwise for the fixed-step schemes, the compiled
  pairs, CVODE and scipy, equal to round-off for heyoka's batch mode (``integrators.batch``,
  ``tests/test_batch.py``); so are its verdicts (``tests/test_ensembles.py``, through the runner).
* **Nothing is lost.** A member whose solution is not ``ok`` (diverged, failed) is run again alone
  (``bench.run.execute.execute_run``: its row is exactly a row of a run alone, without cost, as a diverged run
  has) and the others are timed again as a batch without it. Anything the batch raises (a malformed solution,
  members the batch cannot hold) runs every member alone in this worker. A batch past the per-run time limit,
  or whose worker died, is given back to the runner (``batch_failure``), which runs its members one by one,
  each under the limit.
"""

from __future__ import annotations

import contextlib
import json
from typing import TYPE_CHECKING, Any, Iterable, cast

from foucault_bench.bench.run.calibration import calibration_chunk_cpu_s, scaled_calibration_s
from foucault_bench.bench.run.execute import (
    COUNTERS, NOT_DETERMINISTIC, STATUS_FAILED, STATUS_OK, base_row, check_solution, execute_run, import_plugins,
    makes_monitored_call,
)
from foucault_bench.bench.run.timing import Timing, limit_threads, peak_rss_mb, time_repeated
from foucault_bench.bench.run.worker import describe
from foucault_bench.bench.schema import COLUMN_NAMES, VERDICT_COLUMNS

if TYPE_CHECKING:
    from foucault_bench.bench.run.matrix import RunSpec

ConfigurationKey = tuple[str, str, str]
"""(ensemble, integrator, setting asked for)."""


def configurations(specs: Iterable[RunSpec]) -> dict[ConfigurationKey, list[RunSpec]]:
    """The ensemble members among ``specs`` by configuration, each list in the given order; runs of scenes of
    their own are left out."""
    groups: dict[ConfigurationKey, list[RunSpec]] = {}
    for spec in specs:
        if spec.scene.ensemble:
            groups.setdefault((spec.scene.ensemble, spec.integrator, spec.setting), []).append(spec)
    return groups


def batch_failure(specs: list[RunSpec], matrix_id: str, status: str, reason: str) -> None:
    """What a batch task yields when it gave no rows (past its time limit, its worker died): nothing; the
    runner runs its members one by one (module docstring)."""
    return None


def share_columns(timing: Timing, members: int) -> dict[str, Any]:
    """The cost columns of one member of a batch of ``members`` timed by ``timing`` (module docstring)."""
    return dict(cpu_time_s=timing.cpu_median_s / members, cpu_time_spread_s=timing.cpu_spread_s / members,
                wall_time_s=timing.median_s / members, wall_time_spread_s=timing.spread_s / members,
                repeats=timing.repeats, compile_time_s=timing.compile_s / members,
                cpu_time_ci95_rel=timing.cpu_ci95_rel,
                cpu_time_repeats_s=json.dumps([value / members for value in timing.cpu_repeats_s]),
                calibration_cpu_s=scaled_calibration_s(timing.calibration_chunks_s), batch_members=members)


def run_members(specs: list[RunSpec], matrix_id: str) -> list[dict[str, Any]]:
    """The rows of one configuration's members (``configurations``), in order (module docstring). Never raises
    for what a run does; ``ValueError`` for members of more than one configuration."""
    keys = {(spec.scene.ensemble, spec.integrator, spec.setting) for spec in specs}
    if len(keys) != 1:
        raise ValueError(f"run_members takes the members of one configuration, got {len(keys)}")
    limit_threads()
    try:
        solutions, timing = _timed_batch(specs)
    except BaseException:  # noqa: BLE001 - the batch could not be made: every member alone, its row as alone
        return [execute_run(spec, matrix_id) for spec in specs]
    if timing is None:  # a member did not end ok: it runs alone, the others as a batch without it
        ok = [spec for spec, solution in zip(specs, solutions[0], strict=True) if solution.status == STATUS_OK]
        redone = dict(zip(map(id, ok), run_members(ok, matrix_id) if ok else [], strict=True))
        return [redone[id(spec)] if id(spec) in redone else execute_run(spec, matrix_id) for spec in specs]
    first, timed, last = solutions
    return [_member_row(spec, matrix_id, (member_first, member_timed, member_last), timing, len(specs))
            for spec, member_first, member_timed, member_last in zip(specs, first, timed, last, strict=True)]


def _timed_batch(specs: list[RunSpec]) -> tuple[tuple[list, list, list], Timing | None]:
    """The members' solutions (the verdicts', the first timed repeat's and the last repeat's) and the batch's
    timing, ``None`` when a member's first solution is not ``ok`` (then only the first repeat was made)."""
    from foucault_bench.integrators import Problem, get_integrator
    from foucault_bench.integrators.batch import solve_batch

    spec = specs[0]
    import_plugins(spec.plugins)
    integrator = get_integrator(spec.integrator)
    problems = [member.scene.problem() for member in specs]
    steps = None if spec.kh is None else [cast(float, member.step_s) for member in specs]
    n_out = int(problems[0].t_out.size)

    def solve(monitor: bool) -> list:
        solutions = solve_batch(integrator, problems, step_s=steps, tol=spec.tol, monitor=monitor)
        for solution in solutions:
            check_solution(solution, n_out)
        return solutions

    first_intervals = [Problem(model=problem.model, params=problem.params, t_out=problem.t_out[:2].copy())
                       for problem in problems]

    def warm_up() -> None:
        """Compile or load what the batch calls (bench.run.timing, rule 1b); what fails, the timed call reports."""
        with contextlib.suppress(Exception):
            solve_batch(integrator, first_intervals, step_s=steps, tol=spec.tol, monitor=False)

    timed, last, timing = time_repeated(lambda: solve(False), spec.timing,
                                        accept=lambda solutions: all(s.status == STATUS_OK for s in solutions),
                                        calibrate=calibration_chunk_cpu_s, warm_up=warm_up)
    if timing is None:
        return (timed, timed, timed), None
    first = solve(True) if makes_monitored_call(integrator, spec) else timed  # untimed: + per-step metrics
    return (first, timed, last), timing


def _member_row(spec: RunSpec, matrix_id: str, solutions: tuple[Any, Any, Any], timing: Timing,
                members: int) -> dict[str, Any]:
    """One member's row from its solutions (the verdicts', the first and the last timed repeat's) and its share
    of the batch's timing."""
    from foucault_bench.bench.problems.reference import reference_for
    from foucault_bench.bench.verdicts.columns import compute_verdicts
    from foucault_bench.integrators import get_integrator

    first, timed, last = solutions
    row = base_row(spec, matrix_id)
    scene = spec.scene
    try:
        row.update(family=get_integrator(spec.integrator).family, n_out=int(first.y.shape[0]),
                   energy_conserved=int(scene.model_object.conserves_energy), status=first.status,
                   message=first.message,
                   **{name: None if getattr(first, name) is None else int(getattr(first, name)) for name in COUNTERS})
        if first.step_size_s is not None and spec.kh is not None:  # the loop may shorten the requested step
            row["step_s"] = float(first.step_size_s)
            row["kh"] = row["step_s"] * scene.params.pendulum_frequency_rad_s
        row.update(share_columns(timing, members))
        if not first.y.tobytes() == timed.y.tobytes() == last.y.tobytes():
            row["message"] = "; ".join(filter(None, [row["message"], NOT_DETERMINISTIC]))
        verdicts = compute_verdicts(scene, first, reference_for(scene))
        row.update({name: value for name, value in verdicts.items() if name in COLUMN_NAMES})
    except BaseException as error:  # noqa: BLE001 - one member's failure is its row, never the batch's end
        row.update({name: None for name in VERDICT_COLUMNS})
        row.update(status=STATUS_FAILED, message=f"verdicts: {describe(error)}", precession_rate_rad_s=None)
    row["peak_rss_mb"] = peak_rss_mb()
    return row
