"""The matrix runner: every run of a matrix in worker processes (or on a Dask cluster), one stored row each.

Order of work (``run_matrix``):

1. open a matrix run in the results store (``--resume`` continues the latest one with the same matrix hash
   and skips the run keys it already holds); the matrix run is locked while this process writes to it;
2. per scene, in the workers: the reference and the model-adequacy rows (``bench.run.execute.prepare_scene``),
   stored in the ``adequacy`` table; a scene whose reference cannot be computed has all its runs stored as
   ``failed`` rows with the reason;
3. every run, in the workers (``bench.run.execute.execute_run``: the timed ``solve``, then the verdicts); the
   row is written as soon as the run finishes. The members of an ensemble that share an integrator and a
   setting run first, as one task and one timed batch (``bench.run.ensemble_jobs.run_members``: one row per
   member, its cost an equal share of the batch's); a batch past the per-run time limit, or whose worker
   died, gives no rows, and its members then run one by one, each under the limit.

Nothing is lost when one run fails (bench/README.md, "Nothing is lost"):

* anything a run raises, and any malformed result, becomes a ``failed`` row with the reason
  (``bench.run.execute``);
* a run past its time limit (``Matrix.run_timeout_s``) is stopped, stored with status ``timeout`` and the limit
  in its message, and its worker replaced (``bench.run.local_executor``, ``bench.run.dask_executor``);
* a worker process that dies (a crash in native code, the OOM killer) is replaced; its run is retried once in
  a fresh worker, and stored as ``failed`` if it kills that one too;
* only a signal to this process stops the matrix: SIGINT (exit 130) or SIGTERM (exit 143) mark the matrix run
  ``interrupted`` and end the workers; a second signal ends everything at once. A Dask cluster that goes
  away stops the matrix the same way (``bench.errors.RunInterrupted``); ``--resume`` completes it.

Start-up: the executor (``make_executor``) starts its workers at once, and they import the numerical
libraries while the main process reads and validates the matrix; this module imports no numerical library at
the top, so the main process pays only for what it uses (the matrix, the store). Longer runs are started
first (adaptive before fixed-step, longer scenes and finer settings first), which shortens the tail.

Compile once: the cheapest run of each compiled function (``compile_key``: integrator and model, and ε for
heyoka) runs before every other run (``compile_first``), so that each function is compiled once per machine
into numba's and heyoka's disk caches, and the other workers load it instead of compiling it too. A worker
that reaches a function another is compiling waits for it (each compilation holds its cache entry's lock,
``models.jit``) instead of compiling it too; this order keeps that wait rare.
"""

from __future__ import annotations

import collections
import contextlib
import os
import signal
import sys
import threading
from typing import TYPE_CHECKING, Any, Callable, Iterator, cast

from tqdm import tqdm

from foucault_bench.bench.errors import RunInterrupted
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.run.execute import (
    STATUS_FAILED, checked_row, execute_run, prepare_scene, run_failure, scene_failure,
)
from foucault_bench.bench.run.dask_executor import DaskExecutor
from foucault_bench.bench.run.ensemble_jobs import batch_failure, configurations, run_members
from foucault_bench.bench.run.executors import Executor
from foucault_bench.bench.run.local_executor import LocalExecutor
from foucault_bench.bench.schema import STATUS_TIMEOUT

if TYPE_CHECKING:  # the main process imports this module before its workers start: no numerical library here
    from foucault_bench.bench.problems.scenes import Scene
    from foucault_bench.bench.run.matrix import Matrix, RunSpec
    from foucault_bench.bench.run.store import ResultsStore

__all__ = ["Terminated", "compile_first", "make_executor", "run_matrix"]


class Terminated(KeyboardInterrupt):
    """SIGTERM received: handled like Ctrl-C (the matrix run is marked ``interrupted``), exit status 143."""

    exit_status = 128 + signal.SIGTERM


def _estimated_cost(spec: RunSpec) -> tuple:
    """Sort key putting the likely longest runs first (a longest-processing-time-first heuristic)."""
    periods = spec.scene.duration_s / spec.scene.params.small_swing_period_s
    fineness = 1.0 / spec.kh if spec.kh is not None else 1.0 / cast(float, spec.tol)
    return (spec.kh is not None, -periods, -fineness)


# --- the matrix run -------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _stop_on_signals(executor: Executor) -> Iterator[None]:
    """SIGINT raises ``KeyboardInterrupt`` and SIGTERM ``Terminated`` in the main thread; while the matrix run
    is being closed after that, a second SIGINT or SIGTERM kills the workers and exits at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def at_once(signum: int, frame: Any) -> None:
        executor.kill_now()
        os._exit(128 + signum)

    def first(signum: int, frame: Any) -> None:
        signal.signal(signal.SIGINT, at_once)
        signal.signal(signal.SIGTERM, at_once)
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    previous = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    for signum in previous:
        signal.signal(signum, first)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def run_matrix(matrix: Matrix, store: ResultsStore, *, jobs: int = 1, executor: Executor | None = None,
               resume: bool = False, progress: bool = True) -> str:
    """Run ``matrix`` and store one row per run; return the matrix id.

    Args:
        matrix: a validated matrix (``bench.run.matrix.load_matrix``); its ``run_timeout_s`` bounds every run.
        store: where rows, provenance and adequacy rows go.
        jobs: local worker processes, when no ``executor`` is given.
        executor: where to run (``make_executor``); closed when the matrix run ends.
        resume: continue the latest matrix run with the same matrix hash, skipping stored run keys.
        progress: show progress bars (tqdm, on stderr).

    Raises:
        KeyboardInterrupt, Terminated: SIGINT or SIGTERM (the matrix run is stored as ``interrupted``).
        RunInterrupted: the Dask cluster went away (likewise).
        InputError: the matrix run is locked by another process, or no Dask worker runs this code.
    """
    executor = executor or LocalExecutor(jobs)
    status = "interrupted"
    with _stop_on_signals(executor):
        try:
            executor.check_code(matrix)
            matrix_id, stored = store.start_matrix_run(
                matrix, jobs=executor.jobs if executor.scheduler is None else None, scheduler=executor.scheduler,
                resume=resume)
        except BaseException:
            executor.kill()
            raise
        todo = sorted((spec for spec in matrix.runs if spec.run_key not in stored), key=_estimated_cost)
        try:
            keys_to_run = {scene_key(spec.scene) for spec in todo}
            needed = [scene for scene in matrix.scenes if scene_key(scene) in keys_to_run]
            broken = _prepare_scenes(executor, needed, matrix, store, matrix_id, progress)
            to_execute = []
            for spec in todo:
                if scene_key(spec.scene) in broken:
                    store.write_run(run_failure(spec, matrix_id, STATUS_FAILED, broken[scene_key(spec.scene)]))
                else:
                    to_execute.append(spec)
            _execute_runs(executor, to_execute, matrix, store, matrix_id, progress,
                          already=len(todo) - len(to_execute))
            status = "finished"
        finally:
            if status == "finished":
                executor.close()
            else:
                executor.kill()
            store.finish_matrix_run(matrix_id, status)
    return matrix_id


def _prepare_scenes(executor, scenes: list[Scene], matrix: Matrix, store: ResultsStore, matrix_id: str,
                    progress: bool) -> dict[str, str]:
    """References and adequacy rows of every scene; returns {scene key: reason} for failed references."""
    broken: dict[str, str] = {}
    results = executor.map_unordered(prepare_scene, [(scene, matrix.plugins) for scene in scenes], scene_failure,
                                     timeout_s=None)
    with tqdm(total=len(scenes), desc="references", unit="scene", disable=not progress, file=sys.stderr) as bar:
        for _, ready in results:
            if ready.reference_error:
                broken[ready.scene_key] = ready.reference_error
                bar.write(f"scene {ready.scene}: {ready.reference_error}")
            if ready.adequacy_error:
                bar.write(f"scene {ready.scene}: {ready.adequacy_error}")
            store.write_adequacy(matrix_id, ready.scene, ready.adequacy, scene_key=ready.scene_key)
            bar.update()
    return broken


def compile_key(spec: RunSpec) -> tuple:
    """What a run's compiled code depends on: the integrator and the model (numba's loops and right-hand sides
    are compiled per model); for the taylor family also the tolerance (heyoka compiles one integrator per ε,
    whose Taylor order it sets)."""
    tolerance = spec.tol if dict(spec.declared).get("family") == "taylor" else None
    return spec.integrator, spec.scene.model, tolerance


def compile_first(specs: list[RunSpec]) -> tuple[list[RunSpec], list[RunSpec]]:
    """``specs`` split into the cheapest run of each ``compile_key`` (cheapest first) and the rest (in their
    order). The runner finishes the first group before it starts the second, so that each compiled function is
    built once per machine, by one worker, into numba's and heyoka's disk caches, and every other worker loads
    it from there instead of compiling it again at the same time."""
    cheapest: dict[tuple, RunSpec] = {}
    for spec in specs:
        key = compile_key(spec)
        if key not in cheapest or _estimated_cost(spec) > _estimated_cost(cheapest[key]):
            cheapest[key] = spec
    firsts = sorted(cheapest.values(), key=_estimated_cost, reverse=True)
    chosen = {id(spec) for spec in firsts}
    return firsts, [spec for spec in specs if id(spec) not in chosen]


def _execute_runs(executor, specs: list[RunSpec], matrix: Matrix, store: ResultsStore, matrix_id: str,
                  progress: bool, already: int) -> None:
    counts = collections.Counter(failed=already)
    with tqdm(total=len(specs), desc=f"{matrix.name} runs", unit="run", disable=not progress,
              file=sys.stderr) as bar:
        for spec, row in _rows(executor, specs, matrix, matrix_id, note=bar.write):
            row = checked_row(row, spec, matrix_id)
            store.write_run(row)
            counts[row["status"]] += 1
            bar.set_postfix(failed=counts["failed"], timeout=counts[STATUS_TIMEOUT], diverged=counts["diverged"],
                            refresh=False)
            bar.update()
    lost = getattr(executor, "lost_runs", 0)
    if lost:
        raise RunInterrupted(f"{lost} run(s) were lost with their Dask workers (not stored; `--resume` runs them)")


def _rows(executor, specs: list[RunSpec], matrix: Matrix, matrix_id: str,
          note: Callable[[str], object]) -> Iterator[tuple[RunSpec, Any]]:
    """``(spec, row)`` of every run as it arrives: first the ensembles' configurations, each one batch task
    (``bench.run.ensemble_jobs.run_members``, the cheapest of each compile key first), then every other run
    alone (``execute_run``, ``compile_first``), then one by one the members of batches that gave no rows (past
    the time limit, their worker died)."""
    batches = list(configurations(specs).values())
    by_first = {id(members[0]): members for members in batches}
    alone: list[RunSpec] = []
    for group in compile_first([members[0] for members in batches]) if batches else ():
        tasks = [(by_first[id(spec)], matrix_id) for spec in group]
        for (members, _), rows in executor.map_unordered(run_members, tasks, batch_failure,
                                                         timeout_s=matrix.run_timeout_s):
            if isinstance(rows, list) and len(rows) == len(members):
                yield from zip(members, rows, strict=True)
            else:
                note(f"the batch of {len(members)} members of {members[0].scene.ensemble} ({members[0].integrator} "
                     f"{members[0].setting}) gave no rows (time limit or worker lost): its members run one by one")
                alone.extend(members)
    plain = [spec for spec in specs if not spec.scene.ensemble]
    for group in [*compile_first(plain), alone]:
        if group:
            for (spec, _), row in executor.map_unordered(execute_run, [(spec, matrix_id) for spec in group],
                                                         run_failure, timeout_s=matrix.run_timeout_s):
                yield spec, row


def make_executor(jobs: int, scheduler: str | None = None) -> Executor:
    """Local worker processes, or a connection to the Dask scheduler at ``scheduler`` (``InputError`` if it
    cannot be reached or is not a Dask scheduler)."""
    return DaskExecutor(scheduler) if scheduler else LocalExecutor(jobs)
