"""The built-in scenes: every ``bench/scenes/*.toml`` file (package data), read in name order by the scene reader.

A built-in scene file holds ``[scene.NAME]`` tables in the syntax of a matrix file's inline scenes, read by the
same reader (``bench.problems.scene_reader.read_scene_tables``) with the same checks and messages; a table may
start from a scene of an earlier file with ``base = "NAME"``, and a name may be defined in one file only.
``bench/scenes/builtin.toml`` holds the real pendulums, an Airy scene and the seed note's own setting, with how
they were chosen; ``bench/scenes/ensembles.toml`` the built-in ensembles (``ENSEMBLES``: a table with sweeps,
whose members are scenes); a new file in the folder adds its scenes to ``SCENES``. ``scene_from_mapping`` reads a matrix's
inline scene, which may start from any built-in one.

The scene type and the reader live in ``bench.problems.scene`` and ``bench.problems.scene_reader``; their names
that callers use with the built-in scenes are imported here too (``__all__``).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any, Iterable, Mapping

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.scene import (
    MAX_OUTPUT_POINTS, MAX_SCENE_NAME_LENGTH, MIN_OUTPUT_INTERVALS_PER_PERIOD, SCENE_NAME_PATTERN, Scene, grid_problems,
    physical_limit_problems, scene_name_problem,
)
from foucault_bench.bench.problems.scene_reader import (
    REQUIRED_KEYS, SCENE_KEY_TABLE, SCENE_KEYS, read_scene, read_scene_tables,
)
from foucault_bench.bench.validation import read_toml, short_repr

__all__ = [
    "MAX_OUTPUT_POINTS", "MAX_SCENE_NAME_LENGTH", "MIN_OUTPUT_INTERVALS_PER_PERIOD", "REQUIRED_KEYS",
    "ENSEMBLES", "SCENES", "SCENE_DIRECTORY", "SCENE_KEYS", "SCENE_KEY_TABLE", "SCENE_NAME_PATTERN", "SEED_EARTH_RATE_RAD_S", "Scene",
    "grid_problems", "load_scene_files", "physical_limit_problems", "scene_from_mapping",
    "scene_name_problem",
]

SCENE_DIRECTORY = Path(__file__).resolve().parents[1] / "scenes"
"""The folder of the built-in scene files, ``bench/scenes/*.toml`` (package data)."""

SEED_EARTH_RATE_RAD_S = 2.0 * math.pi / (24.0 * 3600.0)
"""The seed note's ω = 2π/24 h (its §2): the solar, not the sidereal, day; 0.27 % below Ω_E. The scene
``seed_2min`` writes it out (tests/test_scenes.py checks that the two are the same double)."""


SCENE_FILE_TABLES = ("scene", "measurement")
"""The top-level tables of a scene file: scenes, and the measured rates of real halls (``reports.halls``)."""


def load_scene_files(paths: Iterable[Path]) -> dict[str, Scene]:
    """Every scene of the scene files ``paths``, read in the order given, each file's scenes in its order.

    A table may start from a scene of an earlier file (``base = "NAME"``); a name that an earlier file defines
    is an error. Raises ``InputError`` with every problem of the first file that has any, each line naming it.
    """
    scenes: dict[str, Scene] = {}
    taken: dict[str, str] = {}
    for path in paths:
        document, source, _ = read_toml(path, folder=SCENE_DIRECTORY.name, kind="scenes")
        problems: list[str] = [f"{source}: unknown key {short_repr(key)}; a scene file holds [scene.NAME] tables "
                               "and, for real halls, [measurement.NAME] tables (their measured rates, read by the "
                               "report)" for key in document if key not in SCENE_FILE_TABLES]
        loaded = read_scene_tables(document.get("scene", {}), scenes, taken,
                                   functools.partial(_add_problem, problems, source))
        if problems:
            raise InputError(problems)
        scenes.update((scene.name, scene) for scene in loaded)
        taken.update(dict.fromkeys((scene.name for scene in loaded), f"a scene of {path.name}"))
        taken.update(dict.fromkeys((scene.ensemble for scene in loaded if scene.ensemble), f"an ensemble of {path.name}"))
    return scenes


def _add_problem(problems: list[str], source: str, message: str) -> None:
    problems.append(f"{source}: {message}")


_ALL_SCENES = load_scene_files(sorted(SCENE_DIRECTORY.glob("*.toml")))
SCENES: dict[str, Scene] = {name: scene for name, scene in _ALL_SCENES.items() if not scene.ensemble}
"""The built-in scenes by name (the files in name order, each in its own order: the order reports list them)."""
ENSEMBLES: dict[str, tuple[Scene, ...]] = {
    name: tuple(scene for scene in _ALL_SCENES.values() if scene.ensemble == name)
    for name in dict.fromkeys(scene.ensemble for scene in _ALL_SCENES.values() if scene.ensemble)}
"""The built-in ensembles by name (``bench/scenes/ensembles.toml``; ``bench.problems.ensemble``): their members."""


def scene_from_mapping(name: str, mapping: Mapping[str, Any]) -> Scene:
    """A matrix file's inline ``[scene.NAME]`` table as a scene, which may start from a built-in one
    (``base = "NAME"``); ``InputError`` lists every problem at once. Keys: ``SCENE_KEY_TABLE``."""
    return read_scene(name, mapping, SCENES)
