"""Benchmark matrices: which scenes, which integrators, which step sizes and tolerances (a TOML file).

A matrix file (read with ``tomllib``) looks like this (bench/README.md "Benchmark matrices" has the full reference)::

    name = "example"
    description = "what this matrix is for"
    scenes = ["pantheon"]                 # built-in scenes (bench.problems.scenes.SCENES)
    integrators = ["rk4", "verlet", "cvode_bdf"]
    kh = [0.5, 0.25, 0.125]               # fixed-step sweep: step h in units of 1/k = √(L/g)
    tol = [1e-6, 1e-9]                    # adaptive sweep: tolerance handed to the integrator as ``tol``
    plugins = ["my_package.my_integrator"]  # modules imported first (they register integrators)

    release_azimuth_deg = [0, 45, 90]     # optional: every scene once per release azimuth (scene "NAME-az45")

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

Plug-ins (``plugins``) are Python modules: importing one runs its code. They are imported only once the rest
of the matrix is valid, and each must register at least one integrator.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import math
from collections import Counter
import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.reference import REFERENCE_INTEGRATOR, physics_identity
from foucault_bench.bench.problems.scene import Scene, scene_name_problem
from foucault_bench.bench.problems.scene_reader import read_scene_tables
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.bench.provenance import code_version, digest
from foucault_bench.bench.run.timing import TimingPolicy
from foucault_bench.bench.schema import declared_facts, setting_label
from foucault_bench.bench.validation import (
    built_in_names, coarse_steps_problem, is_number, read_toml, run_timeout_problem, setting_problem, short_list,
    short_repr, step_count_problem, suggestion,
)

TOP_LEVEL_KEYS = ("name", "description", "scenes", "scene", "release_azimuth_deg", "integrators", "kh", "tol",
                  "override", "plugins", "timing")
SETTING_KEYS = ("kh", "tol")
RUN_TIMEOUT_KEY = "run_timeout_s"
TIMING_KEYS = (*(field.name for field in dataclasses.fields(TimingPolicy)), RUN_TIMEOUT_KEY)
DEFAULT_RUN_TIMEOUT_S = 600.0
"""Per-run time limit (s) when neither the matrix nor --run-timeout gives one: well above the slowest run of
the built-in matrices (bench/README.md, "Nothing is lost", has the measurement)."""
MAX_OUTPUT_POINTS = 10**7
"""More output points per scene than this is refused (each solution holds 4 doubles per point: 320 MB)."""
MAX_RUNS = 100_000
"""Most runs one matrix may expand to (scenes × settings, summed over its integrators). The default matrix's
1323 runs take about 5 minutes on 2 cores (bench/README.md "Benchmark matrices"), so this is some 6 hours of
2 cores at the same mix, and its validation about a second; a larger study is several matrices (or runs of one
matrix with ``--resume``) rather than one file whose every run is planned in memory before the first starts."""
BUILT_IN_FOLDER = "matrices"
"""Package folder of the built-in matrices (``bench/matrices/NAME.toml``, package data)."""


@dataclass(frozen=True)
class RunSpec:
    """One run of a matrix: a scene, an integrator and its setting (kh for fixed-step, tol for adaptive)."""

    scene: Scene
    integrator: str
    kh: float | None
    tol: float | None
    plugins: tuple[str, ...]
    timing: TimingPolicy
    code_version: str
    declared: tuple[tuple[str, Any], ...] = ()
    """The integrator's declared facts as (results column, value) pairs (``bench.schema.declared_facts``)."""

    @property
    def step_s(self) -> float | None:
        """Requested step h = kh / k in s (the loop may shorten it to fit the output grid)."""
        return None if self.kh is None else self.kh / self.scene.params.pendulum_frequency_rad_s

    @property
    def setting(self) -> str:
        return setting_label(self.kh, self.tol)

    @functools.cached_property
    def run_key(self) -> str:
        """SHA-256 (16 hex digits) of the scene's name and physics, the integrator, its setting and the code
        version."""
        return digest([self.scene.name, physics_identity(self.scene), self.integrator, self.kh, self.tol,
                       self.code_version])


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

    @functools.cached_property
    def matrix_hash(self) -> str:
        """Hash of the name, every run key and the timing policy: equal hashes mean the same work."""
        return digest([self.name, sorted(run.run_key for run in self.runs), dataclasses.asdict(self.timing)])


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
    plugins = _string_list(document, "plugins", lambda message: None, required=False)
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

    plugins = _string_list(document, "plugins", problem, required=False)
    scenes = _release_azimuth_variants(_scenes(document, problem), document.get("release_azimuth_deg"), problem)
    _check_names(scenes, problem)
    timing, run_timeout_s = _timing(document.get("timing", {}), problem)
    runs = _runs(document, scenes, plugins, timing, problem, known_later)
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
    )


def _string_list(document: dict[str, Any], key: str, problem, *, required: bool) -> list[str]:
    if key not in document:
        if required:
            problem(f"{key}: missing (a list of names)")
        return []
    value = document[key]
    if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
        problem(f"{key} must be a list of strings, got {short_repr(value)}")
        return []
    duplicates = sorted(item for item, count in Counter(value).items() if count > 1)
    if duplicates:
        problem(f"{key}: listed more than once: {short_list(short_repr(item) for item in duplicates)}")
    return list(dict.fromkeys(value))


def _scenes(document: dict[str, Any], problem) -> list[Scene]:
    scenes: list[Scene] = []
    for name in _string_list(document, "scenes", problem, required=False):
        if name in SCENES:
            scenes.append(SCENES[name])
        else:
            problem(f"scenes: unknown scene {short_repr(name)}{suggestion(name, SCENES)}; built-in scenes: {', '.join(SCENES)}")
    inline = document.get("scene", {})
    scenes += read_scene_tables(inline, SCENES, dict.fromkeys(SCENES, "a built-in scene"), problem)
    if not document.get("scenes") and not (isinstance(inline, dict) and inline):
        problem("no scenes: list built-in ones in scenes = [...] or define [scene.NAME] tables")
    return scenes


def azimuth_label(azimuth_deg: float) -> str:
    """The azimuth as it appears in a variant's name: the shortest text that reads back as the same float
    (``repr``), with a whole number's ``.0`` and an exponent's ``+`` dropped (``45``, ``45.0000001``, ``1e20``,
    ``1e-05``). Distinct floats get distinct labels (``repr`` round-trips, and neither dropped piece can be
    confused with another float's text), unlike ``:g``, which keeps 6 digits: 45 and 45.0000001 were both
    ``45``."""
    return repr(float(azimuth_deg)).removesuffix(".0").replace("e+", "e")


def _release_azimuth_variants(scenes: list[Scene], azimuths: Any, problem) -> list[Scene]:
    """With ``release_azimuth_deg = [ψ₁, ψ₂, …]``, every scene once per release azimuth (degrees from x = South
    towards y = East), named ``SCENE-azψ`` (ψ by ``azimuth_label``); without it, the scenes as they are."""
    if azimuths is None:
        return scenes
    if (not isinstance(azimuths, list) or not azimuths
            or not all(is_number(value) and math.isfinite(value) for value in azimuths)):
        problem(f"release_azimuth_deg must be a non-empty list of finite numbers (degrees), got {short_repr(azimuths)}")
        return scenes
    if len(set(azimuths)) != len(azimuths):
        problem("release_azimuth_deg: an azimuth is listed more than once")
        azimuths = list(dict.fromkeys(azimuths))  # one variant each: no second problem for the same name
    if len(scenes) * len(azimuths) > MAX_RUNS:
        problem(f"release_azimuth_deg: {len(scenes)} scene(s) × {len(azimuths)} azimuths make more than the "
                f"{MAX_RUNS} runs a matrix may have")
        return scenes
    variants = []
    for scene in scenes:
        for azimuth in azimuths:
            label = azimuth_label(azimuth)
            try:
                variants.append(dataclasses.replace(
                    scene, name=f"{scene.name}-az{label}", title=f"{scene.title}, released at azimuth {label}°",
                    params=dataclasses.replace(scene.params, release_azimuth_deg=float(azimuth)),
                    assumptions=f"{scene.assumptions} Release azimuth swept by the matrix: {label}° from South "
                                "towards East.".strip(),
                ))
            except InputError as error:  # the physical limits depend on the release azimuth
                for message in error.problems:
                    problem(f"release_azimuth_deg = {label} of scene {short_repr(scene.name)}: {message}")
    return variants


def _check_names(scenes: list[Scene], problem) -> None:
    """Every scene of a matrix has a name of at most ``MAX_SCENE_NAME_LENGTH`` characters, which every file
    name a report derives from it fits (``bench.problems.scene``), and a name of its own: rows, references and
    report files are keyed by it."""
    for name, count in Counter(scene.name for scene in scenes).items():
        message = scene_name_problem(name)
        if message:
            problem(message)
        if count > 1:
            problem(f"{count} scenes are named {short_repr(name)} (rows and report files are keyed by the scene name): "
                    "rename the inline scene or change the azimuth")


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


def _sweep(value: Any, key: str, where: str, problem) -> list[float]:
    """A list of kh values (> 0, finite) or tolerances (in (0, 1), at least 2⁻⁵³; ``bench.validation.
    setting_problem``); one problem per bad entry. A list longer than ``MAX_RUNS`` is refused without looking at
    its entries: no matrix could run it."""
    if not isinstance(value, list) or not value:
        problem(f"{where}: {key} must be a non-empty list of numbers, got {short_repr(value)}")
        return []
    if len(value) > MAX_RUNS:
        problem(f"{where}: {key} lists {len(value)} values, more than the {MAX_RUNS} runs a matrix may have")
        return []
    accepted: list[float] = []
    for item in value:
        message = setting_problem(key, item)
        if message:
            problem(f"{where}: {message}")
        else:
            accepted.append(float(item))
    unique = list(dict.fromkeys(accepted))
    if len(unique) < len(accepted):
        duplicates = sorted(item for item, count in Counter(accepted).items() if count > 1)
        problem(f"{where}: {key} lists {short_list(f'{item:g}' for item in duplicates)} more than once")
    return unique


def _runs(document: dict[str, Any], scenes: list[Scene], plugins: list[str], timing: TimingPolicy,
          problem, known_later: bool = False) -> list[RunSpec]:
    from foucault_bench.integrators import REGISTRY  # imported here: plugins must be imported first

    names = _string_list(document, "integrators", problem, required=True)
    if "integrators" in document and isinstance(document["integrators"], list) and not document["integrators"]:
        problem("integrators: the list is empty; name at least one integrator")
    integrators = []
    for name in names:
        if name == REFERENCE_INTEGRATOR:
            problem(f"integrators: {name} computes the references (bench.problems.reference) and is not swept")
        elif name not in REGISTRY and known_later:
            continue
        elif name not in REGISTRY:
            problem(f"integrators: unknown integrator {short_repr(name)}{suggestion(name, REGISTRY)}; "
                    f"known integrators: {', '.join(sorted(set(REGISTRY) - {REFERENCE_INTEGRATOR}))}")
        else:
            integrators.append(REGISTRY[name])
    planned = _planned_runs(document, integrators, len(scenes))
    if planned > MAX_RUNS:
        problem(f"the matrix expands to {planned} runs (scenes × settings, summed over the integrators), more than "
                f"the {MAX_RUNS} a matrix may have: split it into several matrices")
        return []
    shared = {key: _sweep(document[key], key, key, problem) for key in SETTING_KEYS if key in document}

    overrides = document.get("override", {})
    if not isinstance(overrides, dict):
        problem(f"override must be a table of per-integrator tables ([override.NAME]), got {short_repr(overrides)}")
        overrides = {}
    own: dict[str, dict[str, list[float]]] = {}
    for name, table in overrides.items():
        where = f"override.{name}"
        if name not in names:
            problem(f"{where}: {short_repr(name)} is not listed in integrators{suggestion(name, names)}")
            continue
        if not isinstance(table, dict):
            problem(f"{where} must be a table with kh or tol, got {short_repr(table)}")
            continue
        for key, value in table.items():
            if key not in SETTING_KEYS:
                problem(f"{where}: unknown key {short_repr(key)}{suggestion(key, SETTING_KEYS)}; allowed keys: kh, tol")
            else:
                own.setdefault(name, {})[key] = _sweep(value, key, where, problem)

    for where, sweeps in [("kh", shared), *((f"override.{name}", table) for name, table in own.items())]:
        _check_steps_fit(sweeps.get("kh", []), where, scenes, problem)
        _check_work(sweeps.get("kh", []), where, scenes, problem)
    for scene in scenes:
        if scene.n_intervals + 1 > MAX_OUTPUT_POINTS:
            problem(f"scene {short_repr(scene.name)}: its output grid has {scene.n_intervals + 1:.3g} points, more than "
                    f"{MAX_OUTPUT_POINTS:.0e} (duration_s / output_interval_s): raise output_interval_s")

    used = set()
    runs: list[RunSpec] = []
    if known_later:
        return runs
    code = code_version(tuple(plugins))
    for integrator in integrators:
        right, wrong = _setting_keys(integrator)
        kind = "adaptive (give tol)" if integrator.adaptive else "a fixed-step method (give kh)"
        if wrong in own.get(integrator.name, {}):
            problem(f"override.{integrator.name}: {integrator.name} is {kind}; {wrong} does not apply to it")
        sweep = own.get(integrator.name, {}).get(right)
        if sweep is None:
            sweep = shared.get(right)
            used.add(right)
        if sweep is None:
            problem(f"integrators: {integrator.name} is {kind} but no {right} sweep is given "
                    f"(add {right} = [...] or [override.{integrator.name}])")
            continue
        declared = tuple(declared_facts(integrator).items())  # once per integrator: the same for all its runs
        for scene in scenes:
            for value in sweep:
                runs.append(RunSpec(
                    scene=scene,
                    integrator=integrator.name,
                    kh=value if right == "kh" else None,
                    tol=value if right == "tol" else None,
                    plugins=tuple(plugins),
                    timing=timing,
                    code_version=code,
                    declared=declared,
                ))
    for key in shared:
        if key not in used and integrators:
            kind = "fixed-step" if key == "kh" else "adaptive"
            problem(f"{key} is given but no listed {kind} integrator uses it "
                    f"({'tolerances are for adaptive integrators' if key == 'tol' else 'kh is for fixed-step integrators'})")
    return runs


def _setting_keys(integrator: Any) -> tuple[str, str]:
    """(the setting key the integrator takes, the one it does not): tol for an adaptive one, kh otherwise."""
    return ("tol", "kh") if integrator.adaptive else ("kh", "tol")


def _planned_runs(document: dict[str, Any], integrators: list[Any], scene_count: int) -> int:
    """How many runs the matrix would expand to, counted from the lengths of its lists before any entry is
    validated (so that an oversized matrix is refused at once): per integrator, its own sweep or the shared
    one, times the scenes."""
    overrides = document.get("override")
    total = 0
    for integrator in integrators:
        right, _ = _setting_keys(integrator)
        table = overrides.get(integrator.name) if isinstance(overrides, dict) else None
        sweep = table.get(right) if isinstance(table, dict) and right in table else document.get(right)
        total += len(sweep) if isinstance(sweep, list) else 0
    return total * scene_count


def _check_steps_fit(kh_values: list[float], where: str, scenes: list[Scene], problem) -> None:
    """A fixed step is at most one output interval Δ (``integrators.fixed_step``): kh ≤ k·Δ in every scene."""
    for scene in scenes:
        message = coarse_steps_problem(kh_values, scene.params.pendulum_frequency_rad_s, scene.output_interval_s,
                                       f"scene {short_repr(scene.name)}")
        if message:
            problem(f"{where}: {message}")


def _check_work(kh_values: list[float], where: str, scenes: list[Scene], problem) -> None:
    """Refuse a fixed step that needs more than ``MAX_STEPS`` steps: duration·k/kh in a scene."""
    for scene in scenes:
        for value in kh_values:
            message = step_count_problem(value, scene.params.pendulum_frequency_rad_s, scene.duration_s,
                                         f"scene {short_repr(scene.name)}")
            if message:
                problem(f"{where}: {message}")
