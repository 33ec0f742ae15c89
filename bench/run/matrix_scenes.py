"""A matrix's scenes: built-in ones by name, inline ``[scene.NAME]`` tables, release-azimuth variants, names.

``scenes`` lists the built-in scenes (``bench.problems.scenes.SCENES``) and built-in ensembles
(``bench.problems.scenes.ENSEMBLES``, every member a scene) a matrix names, and reads its inline tables with the
scene reader (an inline table with an ``ensemble`` sweep gives its members); ``release_azimuth_variants`` makes
the ``release_azimuth_deg`` variants; ``check_names`` holds every scene to a name of its own that fits a file
name.
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter
from typing import Any

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.ensemble import number_label
from foucault_bench.bench.problems.scene import Scene, scene_name_problem
from foucault_bench.bench.problems.scene_reader import read_scene_tables
from foucault_bench.bench.problems.scenes import ENSEMBLES, SCENES
from foucault_bench.bench.run.matrix_runs import MAX_RUNS, string_list
from foucault_bench.bench.validation import is_number, short_repr, suggestion


def scenes(document: dict[str, Any], problem) -> list[Scene]:
    scenes: list[Scene] = []
    for name in string_list(document, "scenes", problem, required=False):
        if name in SCENES:
            scenes.append(SCENES[name])
        elif name in ENSEMBLES:
            scenes += ENSEMBLES[name]
        else:
            problem(f"scenes: unknown scene {short_repr(name)}{suggestion(name, [*SCENES, *ENSEMBLES])}; built-in "
                    f"scenes: {', '.join(SCENES)}; built-in ensembles: {', '.join(ENSEMBLES)}")
    inline = document.get("scene", {})
    taken = {**dict.fromkeys(SCENES, "a built-in scene"), **dict.fromkeys(ENSEMBLES, "a built-in ensemble")}
    scenes += read_scene_tables(inline, SCENES, taken, problem)
    if not document.get("scenes") and not (isinstance(inline, dict) and inline):
        problem("no scenes: list built-in ones in scenes = [...] or define [scene.NAME] tables")
    return scenes


def azimuth_label(azimuth_deg: float) -> str:
    """The azimuth as it appears in a variant's name (``bench.problems.ensemble.number_label``)."""
    return number_label(azimuth_deg)


def release_azimuth_variants(scenes: list[Scene], azimuths: Any, problem) -> list[Scene]:
    """With ``release_azimuth_deg = [ψ₁, ψ₂, …]``, every scene once per release azimuth (degrees from x = South
    towards y = East), named ``SCENE-azψ`` (ψ by ``azimuth_label``); without it, the scenes as they are."""
    if azimuths is None:
        return scenes
    for ensemble in dict.fromkeys(scene.ensemble for scene in scenes if scene.ensemble):
        problem(f"release_azimuth_deg does not apply to the members of the ensemble {short_repr(ensemble)}: "
                "sweep release_azimuth_deg in its ensemble table instead")
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


def check_names(scenes: list[Scene], problem) -> None:
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

