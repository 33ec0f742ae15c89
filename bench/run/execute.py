"""One run of a matrix, in a worker process: prepare its scene, execute it, and turn whatever happens into a row.

``bench.run.runner`` hands these functions to an executor (``bench.run.executors``); each returns a row or a
value and never raises:

* ``prepare_scene``: the scene's reference (``bench.problems.reference.reference_for``, cached on disk) and its
  model-adequacy rows (``bench.verdicts.adequacy.model_adequacy``), or why the reference failed;
* ``execute_run``: the integrator's ``solve`` on the scene's problem (the scene's output grid, identical for
  every integrator), timed by the protocol of ``bench.run.timing``; the timed call does the same work for every
  integrator, integrate to the output grid (``monitor=False``: no event detection, no streamed metrics);
  turning points and energies are computed from the grid afterwards, by one procedure for all
  (``bench.verdicts.columns.compute_verdicts``). Integrators that stream a verdict ingredient the grid cannot
  give (``Integrator.streams_step_metrics``: the fixed-step loops' per-step energy error) make one extra,
  untimed ``monitor=True`` call, whose states must equal the timed ones, unless the matrix says
  ``step_energy = false`` (``makes_monitored_call``);
* anything a run raises, ``BaseException`` included (``SystemExit``, a ``KeyboardInterrupt`` raised by a
  plug-in), and any malformed result (a counter that is not a non-negative integer, a state of the wrong
  shape) becomes a ``failed`` row with the reason (bench/README.md, "Nothing is lost");
* ``run_failure`` and ``scene_failure``: the row (or scene result) of a task that gave none, its worker having
  died or passed its time limit; ``checked_row``: a row that reached the main process, made storable.

This module imports no numerical library at the top (the main process imports it for ``checked_row`` and
``run_failure``): ``execute_run`` and ``prepare_scene`` import them inside the worker.
"""

from __future__ import annotations

import contextlib
import importlib
import json
import math
import numbers
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.run.calibration import calibration_chunk_cpu_s, scaled_calibration_s
from foucault_bench.bench.run.timing import limit_threads, peak_rss_mb, time_repeated
from foucault_bench.bench.run.worker import describe
from foucault_bench.bench.schema import COLUMN_NAMES, COLUMNS, VERDICT_COLUMNS

if TYPE_CHECKING:  # the main process imports this module before its workers start: no numerical library here
    from foucault_bench.bench.problems.scenes import Scene
    from foucault_bench.bench.run.matrix import RunSpec

__all__ = ["SceneReady", "base_row", "checked_row", "execute_run", "makes_monitored_call", "prepare_scene",
           "run_failure", "scene_failure"]

STATUS_OK, STATUS_DIVERGED, STATUS_FAILED = "ok", "diverged", "failed"  # integrators.base, not imported here
NOT_DETERMINISTIC = "warning: the output differed between repeated calls (not deterministic)"
SOLUTION_STATUSES = (STATUS_OK, STATUS_DIVERGED, STATUS_FAILED)
COUNTERS = ("nfev", "njev", "steps", "rejected_steps")
_SQL_KINDS = {"TEXT": (str,), "REAL": (numbers.Real,), "INTEGER": (numbers.Integral,)}
_PLAIN = {"TEXT": str, "REAL": float, "INTEGER": int}


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


def makes_monitored_call(integrator: Any, spec: RunSpec) -> bool:
    """Whether the run makes the untimed ``monitor=True`` call after its timed repeats: the integrator streams
    a verdict ingredient the grid cannot give and the matrix asks for it (``RunSpec.step_energy``)."""
    return bool(integrator.streams_step_metrics and spec.step_energy)


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
        first = solve(True) if makes_monitored_call(integrator, spec) else timed  # untimed: + per-step metrics
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


def scene_failure(scene: Scene, plugins: tuple[str, ...], status: str, reason: str) -> SceneReady:
    """What preparing a scene gave when its worker died or its task failed."""
    return SceneReady(scene.name, scene_key(scene), [], f"reference failed: {reason}", None)


def run_failure(spec: RunSpec, matrix_id: str, status: str, reason: str) -> dict[str, Any]:
    """The row of a run that could not be executed or finished: its worker died, it passed its time limit
    (``status`` = timeout) or its scene has no reference."""
    row = base_row(spec, matrix_id)
    row.update(status=status, message=reason)
    return row
