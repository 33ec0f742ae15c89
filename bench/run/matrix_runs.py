"""A matrix's runs: the kh and tol sweeps (shared and per integrator), their checks, and one ``RunSpec`` per run.

``bench.run.matrix`` reads the file; this module turns its validated scenes, integrators and sweeps into the
runs (scenes × settings, per integrator), refusing settings whose work is absurd (``MAX_STEPS`` fixed steps in a
run, a step longer than an output interval, more than ``MAX_RUNS`` runs, counted from the lists' lengths before
their entries are checked). ``integrators`` is a list of names or ``"built-in"`` (``integrator_names``). ``string_list`` reads a list of names, for every part of the matrix reader.
"""

from __future__ import annotations

import functools
from collections import Counter
from dataclasses import dataclass
from typing import Any

from foucault_bench.bench.problems.ensemble import member_columns
from foucault_bench.bench.problems.reference import REFERENCE_INTEGRATOR, physics_identity
from foucault_bench.bench.problems.scene import Scene
from foucault_bench.bench.provenance import code_version, digest, ensemble_code_version
from foucault_bench.bench.run.timing import TimingPolicy
from foucault_bench.bench.schema import declared_facts, setting_label
from foucault_bench.bench.validation import (
    coarse_steps_problem, setting_problem, short_list, short_repr, step_count_problem, suggestion,
)

SETTING_KEYS = ("kh", "tol")
BUILT_IN = "built-in"
"""``integrators = "built-in"``: every built-in integrator but the reference (``integrator_names``), so that a
new built-in joins the matrices that say so without an edit."""
MAX_OUTPUT_POINTS = 10**7
"""More output points per scene than this is refused (each solution holds 4 doubles per point: 320 MB)."""
MAX_RUNS = 100_000
"""Most runs one matrix may expand to (scenes × settings, summed over its integrators). The default matrix's
1323 runs take about 5 minutes on 2 cores (bench/README.md "Benchmark matrices"), so this is some 6 hours of
2 cores at the same mix, and its validation about a second; a larger study is several matrices (or runs of one
matrix with ``--resume``) rather than one file whose every run is planned in memory before the first starts."""


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
    """The columns a row takes from the matrix as (results column, value) pairs: the integrator's declared facts
    (``bench.schema.declared_facts``) and, for an ensemble member, its ensemble and swept values
    (``bench.problems.ensemble.member_columns``)."""
    step_energy: bool = True
    """Whether an integrator that streams step metrics (the fixed-step loops) also makes its untimed monitored
    call, for the per-step energy error (``energy_max_rel_error_steps``; the matrix's ``step_energy``,
    ``bench.run.matrix``)."""

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


def string_list(document: dict[str, Any], key: str, problem, *, required: bool) -> list[str]:
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


def read_sweep(value: Any, key: str, where: str, problem) -> list[float]:
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


def runs(document: dict[str, Any], scenes: list[Scene], plugins: list[str], timing: TimingPolicy,
          problem, known_later: bool = False, step_energy: bool = True) -> list[RunSpec]:
    from foucault_bench.integrators import REGISTRY  # imported here: plugins must be imported first

    names = integrator_names(document, problem)
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
    shared = {key: read_sweep(document[key], key, key, problem) for key in SETTING_KEYS if key in document}

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
                own.setdefault(name, {})[key] = read_sweep(value, key, where, problem)

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
    code, ensemble_code = code_version(tuple(plugins)), ensemble_code_version(tuple(plugins))
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
                kh, tol = (value, None) if right == "kh" else (None, value)
                runs.append(RunSpec(
                    scene=scene,
                    integrator=integrator.name,
                    kh=kh,
                    tol=tol,
                    plugins=tuple(plugins),
                    timing=timing,
                    code_version=ensemble_code if scene.ensemble else code,
                    declared=declared + member_columns(scene, setting_label(kh, tol)),
                    step_energy=step_energy,
                ))
    for key in shared:
        if key not in used and integrators:
            kind = "fixed-step" if key == "kh" else "adaptive"
            problem(f"{key} is given but no listed {kind} integrator uses it "
                    f"({'tolerances are for adaptive integrators' if key == 'tol' else 'kh is for fixed-step integrators'})")
    return runs


def integrator_names(document: dict[str, Any], problem) -> list[str]:
    """The matrix's ``integrators``: a list of registry names, or ``BUILT_IN``, every built-in integrator
    (``integrators.built_in_names``, in its order) but the reference integrator, which is never swept."""
    from foucault_bench.integrators import built_in_names  # imported here, like the registry above

    value = document.get("integrators")
    if isinstance(value, str):
        if value == BUILT_IN:
            return [name for name in built_in_names() if name != REFERENCE_INTEGRATOR]
        problem(f"integrators: unknown form {short_repr(value)}{suggestion(value, [BUILT_IN])}; give a list of "
                f"integrator names or {BUILT_IN!r} (every built-in integrator)")
        return []
    names = string_list(document, "integrators", problem, required=True)
    if isinstance(value, list) and not value:
        problem("integrators: the list is empty; name at least one integrator")
    return names


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
