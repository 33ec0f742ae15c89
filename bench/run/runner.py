"""The matrix runner: every run of a matrix in worker processes (or on a Dask cluster), one stored row each.

Order of work (``run_matrix``):

1. open a matrix run in the results store (``--resume`` continues the latest one with the same matrix hash
   and skips the run keys it already holds); the matrix run is locked while this process writes to it;
2. per scene, in the workers: the reference (``bench.problems.reference.reference_for``, cached on disk) and the
   model-adequacy rows (``bench.verdicts.adequacy.model_adequacy``), stored in the ``adequacy`` table; a scene whose
   reference cannot be computed has all its runs stored as ``failed`` rows with the reason;
3. every run (``execute_run``): the integrator's ``solve`` on the scene's problem (the scene's output grid,
   identical for every integrator), timed by the protocol of ``bench.run.timing``; the timed call does the
   same work for every integrator, integrate to the output grid (``monitor=False``: no event detection, no
   streamed metrics); turning points and energies are computed from the grid afterwards, by one procedure for
   all (``bench.verdicts.columns.compute_verdicts``). Integrators that stream a verdict ingredient the grid
   cannot give (``Integrator.streams_step_metrics``: the fixed-step loops' per-step energy error) make one
   extra, untimed ``monitor=True`` call, whose states must equal the timed ones; the row is written as soon as
   the run finishes.

Nothing is lost when one run fails (bench/README.md, "Nothing is lost"):

* anything a run raises, ``BaseException`` included (``SystemExit``, a ``KeyboardInterrupt`` raised by a
  plug-in), and any malformed result (a counter that is not a non-negative integer, a state of the wrong
  shape) becomes a ``failed`` row with the reason;
* a run past its time limit (``Matrix.run_timeout_s``) is stopped, stored with status ``timeout`` and the limit
  in its message, and its worker replaced (``bench.run.executors``);
* a worker process that dies (a crash in native code, the OOM killer) is replaced; its run is retried once in
  a fresh worker, and stored as ``failed`` if it kills that one too;
* only a signal to this process stops the matrix: SIGINT (exit 130) or SIGTERM (exit 143) mark the matrix run
  ``interrupted`` and end the workers; a second signal ends everything at once. A Dask cluster that goes
  away stops the matrix the same way (``bench.errors.RunInterrupted``); ``--resume`` completes it.

Start-up: the executor starts its workers at once (``bench.run.executors``), and they import the numerical
libraries while the main process reads and validates the matrix; this module imports no numerical library at
the top, so the main process pays only for what it uses (the matrix, the store). Longer runs are started
first (adaptive before fixed-step, longer scenes and finer settings first), which shortens the tail.

Compile once: the cheapest run of each compiled function (``compile_key``: integrator and model, and ε for
heyoka) runs before every other run (``compile_first``), so that each function is compiled once per machine
into numba's and heyoka's disk caches, and the other workers load it instead of compiling it too.
"""

from __future__ import annotations

import collections
import contextlib
import importlib
import itertools
import json
import math
import numbers
import os
import signal
import sys
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterator, cast

from tqdm import tqdm

from foucault_bench.bench.errors import RunInterrupted
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.run.calibration import calibration_chunk_cpu_s, scaled_calibration_s
from foucault_bench.bench.run.executors import WORKER_DIED, DaskExecutor, LocalExecutor, make_executor
from foucault_bench.bench.run.timing import limit_threads, peak_rss_mb, time_repeated
from foucault_bench.bench.run.worker import describe
from foucault_bench.bench.schema import COLUMN_NAMES, COLUMNS, STATUS_TIMEOUT, VERDICT_COLUMNS

if TYPE_CHECKING:  # the main process imports this module before its workers start: no numerical library here
    from foucault_bench.bench.problems.scenes import Scene
    from foucault_bench.bench.run.matrix import Matrix, RunSpec
    from foucault_bench.bench.run.store import ResultsStore

__all__ = ["WORKER_DIED", "Terminated", "execute_run", "make_executor", "prepare_scene", "run_matrix"]

STATUS_OK, STATUS_DIVERGED, STATUS_FAILED = "ok", "diverged", "failed"  # integrators.base, not imported here
NOT_DETERMINISTIC = "warning: the output differed between repeated calls (not deterministic)"
SOLUTION_STATUSES = (STATUS_OK, STATUS_DIVERGED, STATUS_FAILED)
COUNTERS = ("nfev", "njev", "steps", "rejected_steps")
_SQL_KINDS = {"TEXT": (str,), "REAL": (numbers.Real,), "INTEGER": (numbers.Integral,)}
_PLAIN = {"TEXT": str, "REAL": float, "INTEGER": int}


class Terminated(KeyboardInterrupt):
    """SIGTERM received: handled like Ctrl-C (the matrix run is marked ``interrupted``), exit status 143."""

    exit_status = 128 + signal.SIGTERM


class MalformedResult(ValueError):
    """An integrator returned something that is not a valid ``Solution`` of its problem."""


@dataclass(frozen=True)
class SceneReady:
    """What preparing a scene gave: its adequacy rows, or why its reference failed."""

    scene: str
    scene_key: str
    adequacy: list[dict[str, Any]]
    reference_error: str | None
    adequacy_error: str | None


def import_plugins(plugins: tuple[str, ...]) -> None:
    """Import the plug-in modules (they register integrators when imported)."""
    for module_name in plugins:
        importlib.import_module(module_name)


def prepare_scene(scene: Scene, plugins: tuple[str, ...] = ()) -> SceneReady:
    """Compute (or load from the disk cache) the scene's reference and its model-adequacy rows."""
    from foucault_bench.bench.verdicts.adequacy import model_adequacy
    from foucault_bench.bench.problems.reference import reference_for

    limit_threads()
    import_plugins(plugins)
    try:
        reference_for(scene)
    except BaseException as error:  # noqa: BLE001 - reported, and the scene's runs become failed rows
        return SceneReady(scene.name, scene_key(scene), [], f"reference failed: {describe(error)}", None)
    try:
        return SceneReady(scene.name, scene_key(scene), list(model_adequacy(scene)), None, None)
    except BaseException as error:  # noqa: BLE001 - adequacy is a side table; the runs do not depend on it
        return SceneReady(scene.name, scene_key(scene), [], None, f"model adequacy failed: {describe(error)}")


def base_row(spec: RunSpec, matrix_id: str) -> dict[str, Any]:
    """The identity columns of a run's row; every other column NULL."""
    row: dict[str, Any] = dict.fromkeys(COLUMN_NAMES)
    row.update(
        run_key=spec.run_key,
        matrix_id=matrix_id,
        scene=spec.scene.name,
        scene_key=scene_key(spec.scene),
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


def check_solution(solution: Any, n_out: int) -> None:
    """Raise ``MalformedResult`` unless ``solution`` is a ``Solution`` the row can be built from: a known
    status, a string message, a finite float state of shape (n_out, 4), counters ``None`` or non-negative
    integers, a step size ``None`` or a positive finite number."""
    import numpy as np

    from foucault_bench.integrators import Solution

    if not isinstance(solution, Solution):
        raise MalformedResult(f"solve returned a {type(solution).__name__}, not a Solution")
    if solution.status not in SOLUTION_STATUSES:
        raise MalformedResult(f"status {solution.status!r} is not one of {', '.join(SOLUTION_STATUSES)}")
    if not isinstance(solution.message, str):
        raise MalformedResult(f"message is a {type(solution.message).__name__}, not a string")
    y = solution.y
    if not isinstance(y, np.ndarray) or y.shape != (n_out, 4) or not np.issubdtype(y.dtype, np.floating):
        shape = getattr(y, "shape", type(y).__name__)
        raise MalformedResult(f"state y must be a float array of shape ({n_out}, 4), got {shape}")
    for name in COUNTERS:
        value = getattr(solution, name)
        if value is None:
            continue
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 0:
            raise MalformedResult(f"{name} must be a non-negative integer or None, got {value!r}")
    step = solution.step_size_s
    if step is not None and not (isinstance(step, (int, float, np.floating)) and not isinstance(step, bool)
                                 and math.isfinite(step) and step > 0):
        raise MalformedResult(f"step_size_s must be a positive finite number or None, got {step!r}")


def execute_run(spec: RunSpec, matrix_id: str) -> dict[str, Any]:
    """Run one matrix entry and return its row (``bench.schema.COLUMNS``). Never raises."""
    from foucault_bench.bench.problems.reference import reference_for
    from foucault_bench.bench.verdicts.columns import compute_verdicts
    from foucault_bench.integrators import Problem, Solution, get_integrator

    limit_threads()
    row = base_row(spec, matrix_id)
    stage = "setup"
    try:
        import_plugins(spec.plugins)
        integrator = get_integrator(spec.integrator)
        row["family"] = integrator.family
        scene = spec.scene
        problem = scene.problem()
        n_out = int(problem.t_out.size)
        row["n_out"] = n_out
        row["energy_conserved"] = int(problem.model.conserves_energy)
        stage = "solve"

        def solve(monitor: bool) -> Solution:
            solution = integrator.solve(problem, step_s=spec.step_s, tol=spec.tol, monitor=monitor)
            check_solution(solution, n_out)
            return solution

        first_interval = Problem(model=problem.model, params=problem.params, t_out=problem.t_out[:2].copy())

        def warm_up() -> None:
            """Compile or load what the run calls (bench.run.timing, rule 1b); what fails here, the timed call
            itself reports."""
            with contextlib.suppress(Exception):
                integrator.solve(first_interval, step_s=spec.step_s, tol=spec.tol, monitor=False)

        timed, last, timing = time_repeated(lambda: solve(False), spec.timing,
                                            accept=lambda solution: solution.status == STATUS_OK,
                                            calibrate=calibration_chunk_cpu_s, warm_up=warm_up)
        first = solve(True) if integrator.streams_step_metrics else timed  # untimed: + per-step metrics
        row.update(status=first.status, message=first.message,
                   **{name: None if getattr(first, name) is None else int(getattr(first, name)) for name in COUNTERS})
        if first.step_size_s is not None and spec.kh is not None:  # the loop may shorten the requested step
            row["step_s"] = float(first.step_size_s)
            row["kh"] = row["step_s"] * scene.params.pendulum_frequency_rad_s
        if timing is not None:
            row.update(cpu_time_s=timing.cpu_median_s, cpu_time_spread_s=timing.cpu_spread_s,
                       wall_time_s=timing.median_s, wall_time_spread_s=timing.spread_s, repeats=timing.repeats,
                       compile_time_s=timing.compile_s, cpu_time_ci95_rel=timing.cpu_ci95_rel,
                       cpu_time_repeats_s=json.dumps(list(timing.cpu_repeats_s)),
                       calibration_cpu_s=scaled_calibration_s(timing.calibration_chunks_s))
            if not first.y.tobytes() == timed.y.tobytes() == last.y.tobytes():
                row["message"] = "; ".join(filter(None, [row["message"], NOT_DETERMINISTIC]))
        stage = "verdicts"  # also for diverged runs: energy and trajectory gaps up to the divergence
        verdicts = compute_verdicts(scene, first, reference_for(scene))
        row.update({name: value for name, value in verdicts.items() if name in COLUMN_NAMES})
    except BaseException as error:  # noqa: BLE001 - one run's failure is a row, never the end of the matrix
        row.update({name: None for name in VERDICT_COLUMNS})
        row.update(status=STATUS_FAILED, message=f"{stage}: {describe(error)}", precession_rate_rad_s=None)
    row["peak_rss_mb"] = peak_rss_mb()
    return row


def checked_row(row: Any, spec: RunSpec, matrix_id: str) -> dict[str, Any]:
    """``row`` if every value fits its column (``bench.schema.COLUMNS``), else a ``failed`` row naming the
    first value that does not: a row that reached the main process is always storable."""
    if not isinstance(row, dict) or set(row) - set(COLUMN_NAMES) or row.get("run_key") != spec.run_key:
        return run_failure(spec, matrix_id, STATUS_FAILED, f"malformed row: {type(row).__name__} {row!r:.80}")
    plain: dict[str, Any] = {}
    for column in COLUMNS:
        value = row.get(column.name)
        try:
            if value is not None and (isinstance(value, bool) or not isinstance(value, _SQL_KINDS[column.sql_type])):
                raise TypeError
            plain[column.name] = None if value is None else _PLAIN[column.sql_type](value)  # numpy scalars too
            if column.sql_type == "INTEGER" and value is not None and abs(plain[column.name]) >= 2**63:
                raise OverflowError
        except (TypeError, ValueError, OverflowError):
            return run_failure(spec, matrix_id, STATUS_FAILED,
                               f"malformed result: {column.name} = {value!r:.80} is not {column.sql_type}")
    return plain


def _estimated_cost(spec: RunSpec) -> tuple:
    """Sort key putting the likely longest runs first (a longest-processing-time-first heuristic)."""
    periods = spec.scene.duration_s / spec.scene.params.small_swing_period_s
    fineness = 1.0 / spec.kh if spec.kh is not None else 1.0 / cast(float, spec.tol)
    return (spec.kh is not None, -periods, -fineness)


def scene_failure(scene: Scene, plugins: tuple[str, ...], status: str, reason: str) -> SceneReady:
    """What preparing a scene gave when its worker died or its task failed."""
    return SceneReady(scene.name, scene_key(scene), [], f"reference failed: {reason}", None)


def run_failure(spec: RunSpec, matrix_id: str, status: str, reason: str) -> dict[str, Any]:
    """The row of a run that could not be executed or finished: its worker died, it passed its time limit
    (``status`` = timeout) or its scene has no reference."""
    row = base_row(spec, matrix_id)
    row.update(status=status, message=reason)
    return row


# --- the matrix run -------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _stop_on_signals(executor: LocalExecutor | DaskExecutor) -> Iterator[None]:
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


def run_matrix(matrix: Matrix, store: ResultsStore, *, jobs: int = 1, executor: LocalExecutor | DaskExecutor |
               None = None, resume: bool = False, progress: bool = True) -> str:
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
    results = itertools.chain.from_iterable(
        executor.map_unordered(execute_run, [(spec, matrix_id) for spec in group], run_failure,
                               timeout_s=matrix.run_timeout_s)
        for group in compile_first(specs))
    with tqdm(total=len(specs), desc=f"{matrix.name} runs", unit="run", disable=not progress,
              file=sys.stderr) as bar:
        for (spec, _), row in results:
            row = checked_row(row, spec, matrix_id)
            store.write_run(row)
            counts[row["status"]] += 1
            bar.set_postfix(failed=counts["failed"], timeout=counts[STATUS_TIMEOUT], diverged=counts["diverged"],
                            refresh=False)
            bar.update()
    lost = getattr(executor, "lost_runs", 0)
    if lost:
        raise RunInterrupted(f"{lost} run(s) were lost with their Dask workers (not stored; `--resume` runs them)")
