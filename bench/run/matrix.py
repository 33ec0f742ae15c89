"""Benchmark matrices: which scenes, which integrators, which step sizes and tolerances (a TOML file).

A matrix file (read with ``tomllib``) looks like this (bench/README.md "Benchmark matrices" has the full reference)::

    name = "example"
    description = "what this matrix is for"
    scenes = ["pantheon"]                 # built-in scenes (bench.problems.scenes.SCENES)
    integrators = ["rk4", "verlet", "cvode_bdf"]  # or "built-in": every built-in integrator but the reference
    kh = [0.5, 0.25, 0.125]               # fixed-step sweep: step h in units of 1/k = √(L/g)
    tol = [1e-6, 1e-9]                    # adaptive sweep: tolerance handed to the integrator as ``tol``
    plugins = ["my_package.my_integrator"]  # modules imported first (they register integrators)

    release_azimuth_deg = [0, 45, 90]     # optional: every scene once per release azimuth (scene "NAME-az45")
    step_energy = false                   # optional (default true): no per-step energy error (below)

    [scene.lab]                           # an inline scene, read by bench.problems.scene_reader
    model = "linear"
    ...

    [override.explicit_euler]             # this integrator's own sweep instead of the shared one
    kh = [0.01, 0.005]

    [timing]                              # the timing protocol (bench.run.timing.TimingPolicy)
    min_repeats = 3
    run_timeout_s = 600                   # per-run time limit (DEFAULT_RUN_TIMEOUT_S); --run-timeout overrides

Step sizes are given as kh = k·h (k = √(g/L)), the quantity the stability limits and error constants are written
in (integrators/README.md "Step sizes in kh"): the step in seconds is h = kh / k, and the fixed-step loop shortens
it (never lengthens it) to fit a whole number of steps in each output interval (``integrators.fixed_step``).

``load_matrix`` refuses a bad file before anything runs and reports every problem at once
(``bench.errors.InputError``), with a suggestion for misspelt names. Validation takes time linear in the
file's size. Settings whose work is absurd are refused with the estimate: more than ``MAX_STEPS`` fixed steps
(duration·k/kh) in a run, more than ``MAX_OUTPUT_POINTS`` points on a scene's output grid, a tolerance below the
double-precision unit roundoff (no double-precision integrator can meet it; ``bench.validation``), or more than
``MAX_RUNS`` runs in the matrix (counted from the lists' lengths before their entries are checked). Variants of a
scene made by ``release_azimuth_deg`` are named with ``azimuth_label``, which keeps distinct azimuths distinct;
no two scenes of a matrix may share a name, and none may have more than ``MAX_SCENE_NAME_LENGTH`` characters
(``bench.problems.scene``: what a report's file names fit).

``step_energy`` (default ``true``): every run of an integrator that streams step metrics (the fixed-step loops)
also makes one untimed call with ``monitor=True``, which streams the energy error of every step (column
``energy_max_rel_error_steps``; the grid's energy error, ``energy_max_rel_error``, is in every row either way).
That call integrates the run once more: with ``false`` the column is NULL and the matrix costs that much less
(the default matrix: about 50 s of CPU of its ~340 s, bench/PERF.md "The per-step energy error made optional").

Plug-ins (``plugins``) are Python modules: importing one runs its code. They are imported only once the rest
of the matrix is valid, and each must register at least one integrator.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.scene import Scene
from foucault_bench.bench.provenance import code_version, digest
from foucault_bench.bench.run.matrix_runs import MAX_OUTPUT_POINTS, MAX_RUNS, RunSpec, string_list
from foucault_bench.bench.run.matrix_runs import runs as matrix_runs
from foucault_bench.bench.run.matrix_scenes import azimuth_label, check_names, release_azimuth_variants
from foucault_bench.bench.run.matrix_scenes import scenes as scene_list
from foucault_bench.bench.run.timing import TimingPolicy
from foucault_bench.bench.validation import built_in_names, is_number, read_toml, run_timeout_problem, short_repr, suggestion

__all__ = ["DEFAULT_RUN_TIMEOUT_S", "code_version", "MAX_OUTPUT_POINTS", "MAX_RUNS", "Matrix", "RunSpec", "azimuth_label",
           "built_in_matrices", "load_matrix", "parse_matrix", "with_run_timeout"]

TOP_LEVEL_KEYS = ("name", "description", "scenes", "scene", "release_azimuth_deg", "integrators", "kh", "tol",
                  "override", "plugins", "timing", "step_energy")
RUN_TIMEOUT_KEY = "run_timeout_s"
TIMING_KEYS = (*(field.name for field in dataclasses.fields(TimingPolicy)), RUN_TIMEOUT_KEY)
DEFAULT_RUN_TIMEOUT_S = 600.0
"""Per-run time limit (s) when neither the matrix nor --run-timeout gives one: well above the slowest run of
the built-in matrices (bench/README.md, "Nothing is lost", has the measurement)."""
BUILT_IN_FOLDER = "matrices"
"""Package folder of the built-in matrices (``bench/matrices/NAME.toml``, package data)."""


@dataclass(frozen=True)
class Matrix:
    """A validated matrix: its runs in file order and where it came from."""

    name: str
    description: str
    source: str
    scenes: tuple[Scene, ...]
    runs: tuple[RunSpec, ...]
    plugins: tuple[str, ...]
    timing: TimingPolicy
    run_timeout_s: float = DEFAULT_RUN_TIMEOUT_S
    step_energy: bool = True

    @functools.cached_property
    def matrix_hash(self) -> str:
        """Hash of the name, every run key, the timing policy and ``step_energy``: equal hashes mean the same work."""
        return digest([self.name, sorted(run.run_key for run in self.runs), dataclasses.asdict(self.timing),
                       self.step_energy])


def built_in_matrices() -> list[str]:
    """Names of the matrices shipped with the package (``bench/matrices/NAME.toml``, package data)."""
    return built_in_names(BUILT_IN_FOLDER)


def load_matrix(name_or_path: str | Path) -> Matrix:
    """Read and validate a matrix: a built-in name (``default``, ``quick``) or a path to a TOML file.

    Raises ``InputError`` listing every problem found, one message each.
    """
    document, source, _ = read_toml(name_or_path, folder=BUILT_IN_FOLDER, kind="matrix")
    default_name = str(name_or_path) if source.startswith("built-in") else Path(name_or_path).stem
    return parse_matrix(document, source=source, default_name=default_name)


def with_run_timeout(matrix: Matrix, run_timeout_s: float | None) -> Matrix:
    """``matrix`` with its per-run time limit replaced by ``run_timeout_s`` (``--run-timeout``) when given."""
    if run_timeout_s is None:
        return matrix
    message = run_timeout_problem(run_timeout_s, "--run-timeout")
    if message:
        raise InputError(message)
    return dataclasses.replace(matrix, run_timeout_s=float(run_timeout_s))


def _plugin_problems(plugins: list[str]) -> list[str]:
    """Import each plug-in module; one message per module that fails to import or registers no integrator."""
    from foucault_bench.integrators import REGISTRY

    problems = []
    for module_name in plugins:
        try:
            importlib.import_module(module_name)
        except BaseException as error:  # noqa: BLE001 - a plug-in's failure (even sys.exit) is a problem to report
            problems.append(f"plugins: cannot import {short_repr(module_name)}: {type(error).__name__}: {error}")
            continue
        own = [name for name, integrator in REGISTRY.items()
               if getattr(integrator, "__module__", "") == module_name
               or getattr(integrator, "__module__", "").startswith(f"{module_name}.")]
        if not own:
            problems.append(f"plugins: {short_repr(module_name)} registers no integrator (a plug-in module must "
                            "register at least one with integrators.register)")
    return problems


def parse_matrix(document: dict[str, Any], *, source: str = "matrix", default_name: str = "matrix") -> Matrix:
    """Validate a parsed matrix document (see the module docstring); raise ``InputError`` with every problem.

    Everything but the integrator names is checked first; only if that is clean are the plug-ins imported
    (importing runs their code) and the integrator names checked against the registry they extend."""
    plugins = string_list(document, "plugins", lambda message: None, required=False)
    first = _validate(document, source, default_name, known_later=bool(plugins))
    if plugins:
        problems = [f"{source}: {message}" for message in _plugin_problems(plugins)]
        if problems:
            raise InputError(problems)
        return _validate(document, source, default_name, known_later=False)
    return first


def _validate(document: dict[str, Any], source: str, default_name: str, known_later: bool) -> Matrix:
    """One pass of ``parse_matrix``; with ``known_later`` unknown integrator names are not reported (a plug-in
    not imported yet may register them) and nothing that needs them is computed."""
    problems: list[str] = []

    def problem(message: str) -> None:
        problems.append(f"{source}: {message}")

    for key in document:
        if key not in TOP_LEVEL_KEYS:
            problem(f"unknown key {short_repr(key)}{suggestion(key, TOP_LEVEL_KEYS)}; allowed keys: {', '.join(TOP_LEVEL_KEYS)}")

    name = document.get("name", default_name)
    if not isinstance(name, str) or not name:
        problem(f"name must be a non-empty string, got {short_repr(name)}")
    description = document.get("description", "")
    if not isinstance(description, str):
        problem(f"description must be a string, got {short_repr(description)}")

    plugins = string_list(document, "plugins", problem, required=False)
    scenes = release_azimuth_variants(scene_list(document, problem), document.get("release_azimuth_deg"), problem)
    check_names(scenes, problem)
    timing, run_timeout_s = _timing(document.get("timing", {}), problem)
    step_energy = document.get("step_energy", True)
    if not isinstance(step_energy, bool):
        problem(f"step_energy must be true or false, got {short_repr(step_energy)}")
        step_energy = True
    runs = matrix_runs(document, scenes, plugins, timing, problem, known_later, step_energy)
    if problems:
        raise InputError(problems)
    if known_later:
        return None  # type: ignore[return-value]  # the second pass builds the matrix
    return Matrix(
        name=name,
        description=description,
        source=source,
        scenes=tuple(scenes),
        runs=tuple(runs),
        plugins=tuple(plugins),
        timing=timing,
        run_timeout_s=run_timeout_s,
        step_energy=step_energy,
    )


def _timing(table: Any, problem) -> tuple[TimingPolicy, float]:
    if not isinstance(table, dict):
        problem(f"timing must be a table, got {short_repr(table)}")
        return TimingPolicy(), DEFAULT_RUN_TIMEOUT_S
    values: dict[str, Any] = {}
    defaults = TimingPolicy()
    run_timeout_s = DEFAULT_RUN_TIMEOUT_S
    for key, value in table.items():
        if key not in TIMING_KEYS:
            problem(f"timing: unknown key {short_repr(key)}{suggestion(key, TIMING_KEYS)}; allowed keys: {', '.join(TIMING_KEYS)}")
            continue
        if key == RUN_TIMEOUT_KEY:
            message = run_timeout_problem(value, f"timing: {key}")
            if message:
                problem(message)
            else:
                run_timeout_s = float(value)
            continue
        wanted = type(getattr(defaults, key))
        if not is_number(value) or (wanted is int and not isinstance(value, int)):
            problem(f"timing: {key} must be {'an integer' if wanted is int else 'a number'}, got {short_repr(value)}")
            continue
        if wanted is float and not math.isfinite(value):
            problem(f"timing: {key} must be finite, got {short_repr(value)}")
            continue
        values[key] = wanted(value)
    policy = TimingPolicy(**values)
    for message in policy.problems():
        problem(message)
    return policy, run_timeout_s

