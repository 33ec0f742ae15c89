"""What ``advise`` is asked: the target (``METRIC=VALUE``), the scene (built-in or a matrix file's inline one) or,
with ``--worst``, the ensemble,
and whether the metric measures an integrator on that scene; each with its problems as one line each."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.ensemble import ENSEMBLE_KEY
from foucault_bench.bench.problems.scene_reader import read_scene_tables
from foucault_bench.bench.problems.scenes import ENSEMBLES, SCENES, Scene, scene_from_mapping
from foucault_bench.bench.verdicts.pareto import ERROR_METRICS


@dataclass(frozen=True)
class Target:
    """An error column (``bench.verdicts.pareto.ERROR_METRICS``) and the largest value accepted."""

    metric: str
    value: float


def parse_target(text: str) -> tuple[Target | None, list[str]]:
    """``METRIC=VALUE`` → a target, or the problems with it."""
    metric, equals, value_text = text.partition("=")
    metric = metric.strip()
    problems = []
    if not equals:
        return None, [f"--target must be METRIC=VALUE (e.g. reference_error=1e-6), got {text!r}"]
    if metric not in ERROR_METRICS:
        problems.append(f"--target: unknown metric {metric!r}; metrics: {', '.join(ERROR_METRICS)}")
    try:
        value = float(value_text)
    except ValueError:
        return None, problems + [f"--target: {value_text.strip()!r} is not a number"]
    if not (math.isfinite(value) and value > 0):
        problems.append(f"--target: the target error must be a finite number > 0, got {value_text.strip()}")
    return (Target(metric, value) if not problems else None), problems


def _inline_tables(matrix_file: str | None) -> tuple[dict[str, Any], list[str]]:
    """The ``[scene.NAME]`` tables of ``matrix_file`` (none without one), or the problem reading it."""
    if matrix_file is None:
        return {}, []
    path = Path(matrix_file)
    try:
        document = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as error:
        return {}, [f"--matrix {matrix_file}: cannot read it: {error}"]
    except tomllib.TOMLDecodeError as error:
        return {}, [f"--matrix {matrix_file}: not valid TOML: {error}"]
    return (document.get("scene", {}) if isinstance(document.get("scene", {}), dict) else {}), []


def resolve_scene(name: str, matrix_file: str | None) -> tuple[Scene | None, list[str]]:
    """A built-in scene, or an inline ``[scene.NAME]`` of ``matrix_file``; or the problems."""
    inline, problems = _inline_tables(matrix_file)
    if problems:
        return None, problems
    if name in inline:
        if not isinstance(inline[name], dict):
            return None, [f"--matrix {matrix_file}: scene.{name} must be a table of scene fields"]
        try:
            return scene_from_mapping(name, inline[name]), []
        except InputError as error:
            return None, [f"--matrix {matrix_file}: scene.{name}: {problem}" for problem in error.problems]
    if name in SCENES:
        return SCENES[name], []
    known = sorted(set(SCENES) | set(inline))
    return None, [f"--scene: unknown scene {name!r}; scenes: {', '.join(known)}"
                  + ("" if matrix_file else " (or define it in a matrix file given with --matrix)")]


def resolve_ensemble(name: str, matrix_file: str | None) -> tuple[tuple[Scene, ...], list[str]]:
    """The members of a built-in ensemble, or of an inline ``[scene.NAME]`` table of ``matrix_file`` with an
    ``ensemble`` table (``bench.problems.ensemble``); or the problems (none found: one problem)."""
    inline, problems = _inline_tables(matrix_file)
    if problems:
        return (), problems
    if name in inline and isinstance(inline[name], dict) and ENSEMBLE_KEY in inline[name]:
        members = read_scene_tables({name: inline[name]}, SCENES, {}, problems.append)
        return tuple(members), [f"--matrix {matrix_file}: {problem}" for problem in problems]
    if name in ENSEMBLES:
        return ENSEMBLES[name], []
    known = sorted(set(ENSEMBLES) | {key for key, table in inline.items()
                                     if isinstance(table, dict) and ENSEMBLE_KEY in table})
    return (), [f"--scene: with --worst, {name!r} must be an ensemble; ensembles: {', '.join(known)}"]


def metric_problem(scene: Scene, target: Target) -> str | None:
    """Why ``target.metric`` does not measure an integrator on ``scene`` (None when it does)."""
    from foucault_bench.bench.verdicts.columns import released_from_rest

    definition = ERROR_METRICS[target.metric]
    if not definition.applies(scene.model):
        return f"--target: {target.metric} does not exist for scene {scene.name!r} ({scene.model} model): " \
               f"{definition.why_not}"
    if target.metric == "analytic_gap_exact" and not released_from_rest(scene.params):
        return f"--target: analytic_gap_exact does not exist for scene {scene.name!r}: the exact solution " \
               "assumes a release from rest"
    return None
