"""The matrix runner: every run of a matrix in worker processes (or on a Dask cluster), one stored row each.

Order of work (``run_matrix``):

1. open a matrix run in the results store (``--resume`` continues the latest one with the same matrix hash
   and skips the run keys it already holds);
2. per scene, in the workers: the reference (``bench.problems.reference.reference_for``, cached on disk) and the
   model-adequacy rows (``bench.problems.adequacy.model_adequacy``), stored in the ``adequacy`` table; a scene whose
   reference cannot be computed has all its runs stored as ``failed`` rows with the reason;
3. every run (``execute_run``): the integrator's ``solve`` on the scene's problem (the scene's output grid,
   identical for every integrator; fixed-step runs stream their step-wise metrics and never store steps),
   timed by the protocol of ``bench.run.timing``, verdicts from ``bench.verdicts.columns.compute_verdicts`` on the
   warm-up call's solution; the row is written as soon as the run finishes.

Nothing is lost when one run fails: an exception anywhere in a run (solver, verdicts, a plug-in) becomes a
``failed`` row with the reason, and a worker process that dies (a crash in a native library, the OOM killer)
is replaced; the runs that were in flight are retried one at a time in a fresh worker, and the one that kills
its worker again is stored as ``failed``.

Start-up: ``LocalExecutor`` starts its workers at once, and each first imports ``WORKER_MODULES`` (``warm_up``),
while the main process reads and validates the matrix; this module imports no numerical library at the top,
so the main process pays only for what it uses (the matrix, the store).

Workers: ``jobs`` processes started with the ``spawn`` method (forking a process that has started numba's,
LLVM's or TBB's threads is unsafe), each made single-threaded by ``bench.run.timing.limit_threads`` before it
imports numpy, so that timings do not depend on how many runs share the machine's cores. Longer runs are
started first (adaptive before fixed-step, longer scenes and finer settings first), which shortens the tail.
"""

from __future__ import annotations

import atexit
import collections
import concurrent.futures
import importlib
import multiprocessing
import os
import sys
import traceback
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Iterator

from tqdm import tqdm

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.schema import COLUMN_NAMES, VERDICT_COLUMNS
from foucault_bench.bench.run.timing import limit_threads, peak_rss_mb, time_repeated

if TYPE_CHECKING:  # the main process imports this module before its workers start (module docstring)
    from foucault_bench.bench.problems.scenes import Scene
    from foucault_bench.bench.run.matrix import Matrix, RunSpec
    from foucault_bench.bench.run.store import ResultsStore

WORKER_MODULES = (
    "heyoka",  # the reference integrator's library: imported before any timed call, never counted as compile time
    "foucault_bench.integrators",
    "foucault_bench.bench.problems.reference",
    "foucault_bench.bench.problems.adequacy",
    "foucault_bench.bench.verdicts.columns",
)
"""What a worker imports to run (integrators, references, adequacy, verdicts): imported where they are used and
by ``warm_up``, not at the top, so that the main process, which never runs a scene, does not pay for them."""

NOT_DETERMINISTIC = "warning: the output differed between repeated calls (not deterministic)"
DASK_CONNECT_TIMEOUT_S = 10.0
WORKER_DIED = "the worker process died during this run (crash in native code or killed, e.g. out of memory)"


@dataclass(frozen=True)
class SceneReady:
    """What preparing a scene gave: its adequacy rows, or why its reference failed."""

    scene: str
    adequacy: list[dict[str, Any]]
    reference_error: str | None
    adequacy_error: str | None


def _import_plugins(plugins: tuple[str, ...]) -> None:
    for module_name in plugins:
        importlib.import_module(module_name)


def _describe(error: BaseException) -> str:
    """``Type: message (file:line)`` of the innermost frame, short enough for a table cell."""
    frames = traceback.extract_tb(error.__traceback__)
    where = f" ({frames[-1].filename.rsplit('/', 1)[-1]}:{frames[-1].lineno})" if frames else ""
    return f"{type(error).__name__}: {error}{where}"


def start_worker() -> None:
    """Initializer of a local worker process: one thread per native pool (``limit_threads``), and an exit
    without the interpreter's finalization once the pool shuts the worker down (``_exit_at_once``)."""
    limit_threads()
    atexit.register(_exit_at_once)


def _exit_at_once() -> None:
    """End a finished worker at once (``os._exit``). Its results are already sent (the pool's result queue
    writes synchronously); what is skipped is tearing down the numerical libraries, measured at 0.5-1.2 s per
    worker after a small matrix (bench/PERF.md "Start-up"), paid by every ``run`` while it waits for its
    workers to end. Registered last, it runs first of the exit handlers."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def warm_up() -> None:
    """Import ``WORKER_MODULES`` (a worker's first task, while the main process validates the matrix)."""
    limit_threads()
    for module_name in WORKER_MODULES:
        importlib.import_module(module_name)


def prepare_scene(scene: Scene, plugins: tuple[str, ...] = ()) -> SceneReady:
    """Compute (or load from the disk cache) the scene's reference and its model-adequacy rows."""
    from foucault_bench.bench.problems.adequacy import model_adequacy
    from foucault_bench.bench.problems.reference import reference_for

    limit_threads()
    _import_plugins(plugins)
    try:
        reference_for(scene)
    except Exception as error:  # reported, and the scene's runs become failed rows
        return SceneReady(scene.name, [], f"reference failed: {_describe(error)}", None)
    try:
        return SceneReady(scene.name, list(model_adequacy(scene)), None, None)
    except Exception as error:  # adequacy is a side table; the runs do not depend on it
        return SceneReady(scene.name, [], None, f"model adequacy failed: {_describe(error)}")


def base_row(spec: RunSpec, matrix_id: str) -> dict[str, Any]:
    """The identity columns of a run's row; every other column NULL."""
    row: dict[str, Any] = dict.fromkeys(COLUMN_NAMES)
    row.update(
        run_key=spec.run_key,
        matrix_id=matrix_id,
        scene=spec.scene.name,
        model=spec.scene.model,
        integrator=spec.integrator,
        kh=spec.kh,
        step_s=spec.step_s,
        tol=spec.tol,
        duration_s=spec.scene.duration_s,
        message="",
    )
    row.update(spec.declared)  # the integrator's declared facts (bench.schema.DECLARED_FACTS)
    return row


def execute_run(spec: RunSpec, matrix_id: str) -> dict[str, Any]:
    """Run one matrix entry and return its row (``bench.schema.COLUMNS``). Never raises."""
    from foucault_bench.bench.problems.reference import reference_for
    from foucault_bench.bench.verdicts.columns import compute_verdicts
    from foucault_bench.integrators import STATUS_FAILED, STATUS_OK, get_integrator

    limit_threads()
    row = base_row(spec, matrix_id)
    stage = "setup"
    try:
        _import_plugins(spec.plugins)
        integrator = get_integrator(spec.integrator)
        row["family"] = integrator.family
        scene = spec.scene
        problem = scene.problem()
        row["n_out"] = int(problem.t_out.size)
        row["energy_conserved"] = int(problem.model.conserves_energy)
        stage = "solve"
        first, last, timing = time_repeated(
            lambda: integrator.solve(problem, step_s=spec.step_s, tol=spec.tol, monitor=True),
            spec.timing,
            accept=lambda solution: solution.status == STATUS_OK,
        )
        row.update(
            status=first.status,
            message=first.message,
            nfev=first.nfev,
            njev=first.njev,
            steps=first.steps,
            rejected_steps=first.rejected_steps,
        )
        if first.step_size_s is not None and spec.kh is not None:  # the loop may shorten the requested step
            row["step_s"] = first.step_size_s
            row["kh"] = first.step_size_s * scene.params.pendulum_frequency_rad_s
        if timing is not None:
            row.update(wall_time_s=timing.median_s, wall_time_spread_s=timing.spread_s, repeats=timing.repeats,
                       compile_time_s=timing.compile_s)
            if first.y.tobytes() != last.y.tobytes():
                row["message"] = "; ".join(filter(None, [row["message"], NOT_DETERMINISTIC]))
        stage = "verdicts"  # also for diverged runs: energy and trajectory gaps up to the divergence
        verdicts = compute_verdicts(scene, first, reference_for(scene))
        row.update({name: value for name, value in verdicts.items() if name in COLUMN_NAMES})
    except Exception as error:  # one run's failure is a row, never a crash of the matrix
        row.update({name: None for name in VERDICT_COLUMNS})
        row.update(status=STATUS_FAILED, message=f"{stage}: {_describe(error)}", precession_rate_rad_s=None)
    row["peak_rss_mb"] = peak_rss_mb()
    return row


def _estimated_cost(spec: RunSpec) -> tuple:
    """Sort key putting the likely longest runs first (a longest-processing-time-first heuristic)."""
    periods = spec.scene.duration_s / spec.scene.params.small_swing_period_s
    fineness = 1.0 / spec.kh if spec.kh is not None else 1.0 / spec.tol
    return (spec.kh is not None, -periods, -fineness)


# --- executors ------------------------------------------------------------------------------------------------


class LocalExecutor:
    """``jobs`` single-threaded worker processes (spawn), replaced when one dies (see the module docstring)."""

    scheduler = None

    def __init__(self, jobs: int):
        self.jobs = jobs
        self.pool = self._new_pool(jobs)
        for _ in range(jobs):  # one per worker: each spawns now and imports while the main process validates
            self.pool.submit(warm_up)

    @staticmethod
    def _new_pool(workers: int) -> concurrent.futures.ProcessPoolExecutor:
        return concurrent.futures.ProcessPoolExecutor(
            max_workers=workers, mp_context=multiprocessing.get_context("spawn"), initializer=start_worker)

    def map_unordered(self, function: Callable, tasks: list[tuple], on_worker_death: Callable) -> Iterator:
        """Yield ``function(*task)`` for every task as results arrive, at most ``jobs`` in flight. A task whose
        worker died is retried alone in a fresh worker; if it kills that one too, ``on_worker_death(*task)``
        is yielded in its place."""
        waiting = collections.deque(tasks)
        in_flight: dict[concurrent.futures.Future, tuple] = {}
        while waiting or in_flight:
            while waiting and len(in_flight) < self.jobs:
                task = waiting.popleft()
                in_flight[self.pool.submit(function, *task)] = task
            done, _ = concurrent.futures.wait(in_flight, return_when=concurrent.futures.FIRST_COMPLETED)
            suspects = []
            for future in done:
                task = in_flight.pop(future)
                try:
                    yield future.result()
                except BrokenProcessPool:
                    suspects.append(task)
            if suspects:  # the whole pool is broken: every task still in flight is lost with it
                suspects.extend(in_flight.values())
                in_flight.clear()
                self.pool.shutdown(wait=True, cancel_futures=True)
                yield from self._run_alone(function, suspects, on_worker_death)
                self.pool = self._new_pool(self.jobs)

    def _run_alone(self, function: Callable, tasks: list[tuple], on_worker_death: Callable) -> Iterator:
        for task in tasks:
            with self._new_pool(1) as pool:
                try:
                    yield pool.submit(function, *task).result()
                except BrokenProcessPool:
                    yield on_worker_death(*task)

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


class DaskExecutor:
    """The same work on a Dask distributed cluster (``dask.distributed.Client``). Dask retries a task whose
    worker died on another worker and gives up with ``KilledWorker`` (its ``allowed-failures`` setting);
    that error, like any other raised by a task, becomes ``on_worker_death``."""

    def __init__(self, address: str):
        from distributed import Client

        try:
            self.client = Client(address, timeout=f"{DASK_CONNECT_TIMEOUT_S}s", set_as_default=False)
        except (OSError, TimeoutError, ValueError) as error:
            raise InputError(f"--scheduler: cannot connect to the Dask scheduler at {address!r}: {error}") from None
        self.scheduler = address

    def map_unordered(self, function: Callable, tasks: list[tuple], on_worker_death: Callable) -> Iterator:
        from distributed import as_completed

        futures = {
            self.client.submit(function, *task, pure=False, priority=len(tasks) - index): task
            for index, task in enumerate(tasks)
        }
        for future in as_completed(futures, loop=self.client.loop):
            try:
                yield future.result()
            except Exception as error:  # KilledWorker, lost connection: a row, not a crash
                yield on_worker_death(*futures[future], reason=_describe(error))
            finally:
                future.release()

    def close(self) -> None:
        self.client.close()


# --- the matrix run -------------------------------------------------------------------------------------------


def _scene_failure(scene: Scene, plugins: tuple[str, ...], reason: str = WORKER_DIED) -> SceneReady:
    """What preparing a scene gave when its worker died or Dask gave up on it."""
    return SceneReady(scene.name, [], f"reference failed: {reason}", None)


def _run_failure(spec: RunSpec, matrix_id: str, reason: str = WORKER_DIED) -> dict[str, Any]:
    """The row of a run that could not be executed (its worker died, or its scene has no reference)."""
    from foucault_bench.integrators import STATUS_FAILED

    row = base_row(spec, matrix_id)
    row.update(status=STATUS_FAILED, message=reason)
    return row


def make_executor(jobs: int, scheduler: str | None = None) -> LocalExecutor | DaskExecutor:
    """Local worker processes, or a connection to the Dask scheduler at ``scheduler`` (``InputError`` if it
    cannot be reached)."""
    return DaskExecutor(scheduler) if scheduler else LocalExecutor(jobs)


def run_matrix(matrix: Matrix, store: ResultsStore, *, jobs: int = 1, executor: LocalExecutor | DaskExecutor |
               None = None, resume: bool = False, progress: bool = True) -> str:
    """Run ``matrix`` and store one row per run; return the matrix id.

    Args:
        matrix: a validated matrix (``bench.run.matrix.load_matrix``).
        store: where rows, provenance and adequacy rows go.
        jobs: local worker processes, when no ``executor`` is given.
        executor: where to run (``make_executor``); closed when the matrix run ends.
        resume: continue the latest matrix run with the same matrix hash, skipping stored run keys.
        progress: show progress bars (tqdm, on stderr).
    """
    executor = executor or LocalExecutor(jobs)
    matrix_id, stored = store.start_matrix_run(
        matrix, jobs=executor.jobs if executor.scheduler is None else None, scheduler=executor.scheduler,
        resume=resume)
    todo = sorted((spec for spec in matrix.runs if spec.run_key not in stored), key=_estimated_cost)
    status = "interrupted"
    try:
        needed = [scene for scene in matrix.scenes if any(spec.scene.name == scene.name for spec in todo)]
        broken = _prepare_scenes(executor, needed, matrix, store, matrix_id, progress)
        to_execute = []
        for spec in todo:
            if spec.scene.name in broken:
                store.write_run(_run_failure(spec, matrix_id, broken[spec.scene.name]))
            else:
                to_execute.append(spec)
        _execute_runs(executor, to_execute, matrix, store, matrix_id, progress, already=len(todo) - len(to_execute))
        status = "finished"
    finally:
        executor.close()
        store.finish_matrix_run(matrix_id, status)
    return matrix_id


def _prepare_scenes(executor, scenes: list[Scene], matrix: Matrix, store: ResultsStore, matrix_id: str,
                    progress: bool) -> dict[str, str]:
    """References and adequacy rows of every scene; returns {scene name: reason} for failed references."""
    broken: dict[str, str] = {}
    results = executor.map_unordered(prepare_scene, [(scene, matrix.plugins) for scene in scenes], _scene_failure)
    with tqdm(total=len(scenes), desc="references", unit="scene", disable=not progress, file=sys.stderr) as bar:
        for ready in results:
            if ready.reference_error:
                broken[ready.scene] = ready.reference_error
                bar.write(f"scene {ready.scene}: {ready.reference_error}")
            if ready.adequacy_error:
                bar.write(f"scene {ready.scene}: {ready.adequacy_error}")
            store.write_adequacy(matrix_id, ready.scene, ready.adequacy)
            bar.update()
    return broken


def _execute_runs(executor, specs: list[RunSpec], matrix: Matrix, store: ResultsStore, matrix_id: str,
                  progress: bool, already: int) -> None:
    counts = collections.Counter(failed=already)
    results = executor.map_unordered(execute_run, [(spec, matrix_id) for spec in specs], _run_failure)
    with tqdm(total=len(specs), desc=f"{matrix.name} runs", unit="run", disable=not progress,
              file=sys.stderr) as bar:
        for row in results:
            store.write_run(row)
            counts[row["status"]] += 1
            bar.set_postfix(failed=counts["failed"], diverged=counts["diverged"], refresh=False)
            bar.update()
