"""Reading scenes from TOML tables: the keys a ``[scene.NAME]`` table may hold, their checks and their defaults.

One reader for every scene written as data: a matrix file's inline ``[scene.NAME]`` tables (``bench.run.matrix``)
and the built-in scene files ``bench/scenes/*.toml`` (``bench.problems.scenes``) go through ``read_scene_tables``
and ``read_scene``, with the same checks and messages. ``SCENE_KEY_TABLE`` is the list of keys, their meaning and
default; bench/README.md "Scenes" shows it as printed by ``python -m foucault_bench.bench.problems.scene_reader``.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import re
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.ensemble import ENSEMBLE_KEY, SWEPT_FIELDS, read_members
from foucault_bench.bench.problems.scene import Scene, grid_problems, scene_name_problem
from foucault_bench.bench.validation import finite_number, is_number, short_repr, suggestion
from foucault_bench.models import MODELS, PendulumParameters
from foucault_bench.models.parameters import STANDARD_GRAVITY_M_S2

DEFAULT_PERIOD_FRACTION = 8
"""Without ``output_interval_s``, a scene samples about an eighth of the small-swing period."""


@dataclass(frozen=True)
class SceneKey:
    """One key of a scene table.

    Attributes:
        name: the key.
        meaning: what its value is (units in the key's suffix or here).
        default: the value when the table leaves the key out; ``None``: required unless the table starts from
            ``base``. A text's default may name the scene as ``{name}``.
        default_note: how the default follows from other keys, when it is not one value.
    """

    name: str
    meaning: str
    default: Any = None
    default_note: str = ""


def _attribute_texts(cls: type) -> dict[str, str]:
    """The ``Attributes:`` section of a class docstring: name → text (continuation lines joined)."""
    texts: dict[str, str] = {}
    section = inspect.cleandoc(cls.__doc__ or "").partition("Attributes:")[2]
    name = None
    for line in section.splitlines():
        entry = re.match(r" {4}(\w+): (.*)", line)
        if entry:
            name = entry.group(1)
            texts[name] = entry.group(2).strip()
        elif name and line.startswith(" " * 8):
            texts[name] += " " + line.strip()
        elif line.strip():
            break
    return texts


def parameter_keys(parameters_class: type = PendulumParameters) -> tuple[SceneKey, ...]:
    """One key per ``PendulumParameters`` field, in field order: its meaning (the rule's ``meaning``, else the
    class docstring's line), its default."""
    meanings = _attribute_texts(parameters_class)
    return tuple(
        SceneKey(field.name, field.metadata.get("meaning") or meanings.get(field.name, ""),
                 None if field.default is dataclasses.MISSING else field.default)
        for field in dataclasses.fields(parameters_class)
    )


SCENE_KEY_TABLE: tuple[SceneKey, ...] = (
    SceneKey("base", "a built-in scene to start from: the table then gives only the keys it changes",
             default_note="none: the table gives every required key"),
    SceneKey("model", "model registry name (models/README.md \"The models\"; an unknown name is refused with the list)"),
    *parameter_keys(),
    SceneKey("duration_s", "integrated time span (s), a whole number of output intervals"),
    SceneKey("output_interval_s", "spacing (s) of the uniform output grid 0, Δ, 2Δ, …, duration shared by every "
             "integrator of the scene and its reference; at most 1/5 of the small-swing period",
             default_note=f"the largest interval of at most period/{DEFAULT_PERIOD_FRACTION} that divides the "
                          "duration"),
    SceneKey("title", "one line for reports", default="inline scene {name}"),
    SceneKey("why_model", "why `model` is enough for what the scene measures, with numbers",
             default="chosen by the matrix file"),
    SceneKey("source", "where the numbers come from", default="inline scene of a matrix file"),
    SceneKey("assumptions", "what the scene assumes where the sources say nothing (amplitude, duration, release)",
             default=""),
    SceneKey(ENSEMBLE_KEY, f"a table of sweeps over {', '.join(SWEPT_FIELDS)} (lists or {{start, stop, step}} "
             "ranges): the table then gives one scene per combination, NAME.LABEL (bench.problems.ensemble)",
             default_note="none: one scene"),
)
"""Every key a scene table may hold, in the order bench/README.md lists them."""

SCENE_KEYS = tuple(key.name for key in SCENE_KEY_TABLE)
PARAMETER_KEYS = tuple(field.name for field in dataclasses.fields(PendulumParameters))
TEXT_KEYS = ("title", "why_model", "source", "assumptions")
REQUIRED_KEYS = tuple(key.name for key in SCENE_KEY_TABLE if key.default is None and not key.default_note)
TEXT_DEFAULTS = {key.name: key.default for key in SCENE_KEY_TABLE if key.name in TEXT_KEYS}


def default_output_interval(period_s: float, duration_s: float) -> float:
    """The largest interval (s) of at most period/8 that divides ``duration_s`` into whole intervals."""
    return duration_s / math.ceil(DEFAULT_PERIOD_FRACTION * duration_s / period_s)


def read_scene_tables(tables: Any, bases: Mapping[str, Scene], taken: Mapping[str, str],
                      problem: Callable[[str], None]) -> list[Scene]:
    """The scenes of a document's ``scene`` value (``[scene.NAME]`` tables), in the document's order.

    ``bases``: the scenes a table may start from (``base = "NAME"``); ``taken``: names already in use, each with
    what uses it (``a built-in scene``). Every problem goes to ``problem`` as one line starting with the table's
    name (``scene.NAME: ...``); a table with problems gives no scene.
    """
    if not isinstance(tables, dict):
        problem(f"scene must be a table of inline scenes ([scene.NAME]), got {short_repr(tables)}")
        return []
    scenes: list[Scene] = []
    for name, mapping in tables.items():
        where = f"scene.{name}" if scene_name_problem(name) is None else f"scene.{short_repr(name)}"  # one line
        if name in taken:
            problem(f"{where}: the name {short_repr(name)} is taken by {taken[name]}; choose another name")
            continue
        if not isinstance(mapping, dict):
            problem(f"{where} must be a table of scene fields, got {short_repr(mapping)}")
            continue
        if ENSEMBLE_KEY in mapping:
            scenes += read_members(name, mapping, functools.partial(_read_with_bases, bases=bases),
                                   functools.partial(_prefixed, problem, where))
            continue
        try:
            scenes.append(read_scene(name, mapping, bases))
        except InputError as error:
            for message in error.problems:
                problem(f"{where}: {message}")
    return scenes


def _read_with_bases(name: str, mapping: Mapping[str, Any], *, bases: Mapping[str, Scene]) -> Scene:
    return read_scene(name, mapping, bases)


def _prefixed(problem: Callable[[str], None], where: str, message: str) -> None:
    problem(f"{where}: {message}")


def read_scene(name: str, mapping: Mapping[str, Any], bases: Mapping[str, Scene]) -> Scene:
    """A scene from one ``[scene.NAME]`` table; ``InputError`` lists every problem at once.

    Keys: ``SCENE_KEY_TABLE``. ``base = "NAME"`` starts from the scene ``bases[NAME]``, so that only the changed
    keys need to be given; without it the ``REQUIRED_KEYS`` are required.
    """
    problems: list[str] = []
    if not isinstance(mapping, Mapping):
        raise InputError([f"a scene must be a table of fields, got {short_repr(mapping)}"])
    if ENSEMBLE_KEY in mapping:
        problems.append(f"{ENSEMBLE_KEY}: a table with sweeps is several scenes, read with read_scene_tables")
    for key in mapping:
        if key not in SCENE_KEYS:
            problems.append(f"unknown key {short_repr(key)}{suggestion(str(key), SCENE_KEYS)}; "
                            f"known keys: {', '.join(SCENE_KEYS)}")
    values: dict[str, Any] = {}
    base_name = mapping.get("base")
    if base_name is not None:
        if isinstance(base_name, str) and base_name in bases:
            base = bases[base_name]
            values.update(dataclasses.asdict(base.params))
            values.update(model=base.model, duration_s=base.duration_s, output_interval_s=base.output_interval_s,
                          title=f"{base.title} (variant {name})", source=base.source,
                          why_model=f"inherited from the built-in scene {base_name!r} (check that it still holds "
                                    f"for the changed fields): {base.why_model}",
                          assumptions=base.assumptions)
        else:
            problems.append(f"base: unknown scene {short_repr(base_name)}{suggestion(str(base_name), bases)}; "
                            f"built-in scenes: {', '.join(bases)}")
    values.update({key: value for key, value in mapping.items() if key in SCENE_KEYS and key != "base"})
    if base_name is None:
        missing = [key for key in REQUIRED_KEYS if key not in values]
        if missing:
            problems.append(f"missing key(s): {', '.join(missing)} (or start from a built-in scene with base = ...)")
    problems += _field_problems(values)
    if problems:
        raise InputError(problems)

    parameter_values = {key: values[key] for key in PARAMETER_KEYS if key in values}
    if "release_velocity_m_s" in parameter_values:
        parameter_values["release_velocity_m_s"] = tuple(parameter_values["release_velocity_m_s"])
    try:
        params = PendulumParameters(**parameter_values)
    except ValueError as error:  # anything the field checks above did not catch
        raise InputError([str(error)]) from None
    duration = float(values["duration_s"])
    texts = {key: values.get(key, TEXT_DEFAULTS[key].format(name=name)) for key in TEXT_KEYS}
    return Scene(
        name=name,
        model=values["model"],
        params=params,
        duration_s=duration,
        output_interval_s=float(values.get("output_interval_s",
                                           default_output_interval(params.small_swing_period_s, duration))),
        **texts,
    )


def _field_problems(values: Mapping[str, Any]) -> list[str]:
    """One message per field of wrong type or outside its range (the ranges of ``PendulumParameters``)."""
    problems: list[str] = []
    numbers = {
        "length_m": ("m", lambda v: v > 0, "> 0"),
        "latitude_deg": ("degrees, north positive", lambda v: -90.0 <= v <= 90.0, "within [-90, 90]"),
        "amplitude_m": ("m", lambda v: v > 0, "> 0"),
        "gravity_m_s2": ("m/s²", lambda v: v > 0, "> 0"),
        "earth_rate_rad_s": ("rad/s", lambda v: v >= 0, ">= 0"),
        "release_azimuth_deg": ("degrees", lambda v: True, "finite"),
        "duration_s": ("s", lambda v: v > 0, "> 0"),
        "output_interval_s": ("s", lambda v: v > 0, "> 0"),
    }
    for key, (unit, in_range, condition) in numbers.items():
        if key not in values:
            continue
        value = values[key]
        if not finite_number(value):
            problems.append(f"{key} must be a finite number ({unit}), got {short_repr(value)}")
        elif not in_range(value):
            problems.append(f"{key} must be {condition} ({unit}), got {short_repr(value)}")
    length, amplitude = values.get("length_m"), values.get("amplitude_m")
    if is_number(length) and is_number(amplitude) and length > 0 and amplitude >= length:
        problems.append(f"amplitude_m = {short_repr(amplitude)} m must be less than length_m = {short_repr(length)} m "
                        "(the release point lies on the sphere of radius L, below the pivot)")
    velocity = values.get("release_velocity_m_s")
    if velocity is not None and not (
        isinstance(velocity, (list, tuple)) and len(velocity) == 2
        and all(finite_number(v) for v in velocity)
    ):
        problems.append(f"release_velocity_m_s must be a pair [vx, vy] of finite numbers (m/s), got {short_repr(velocity)}")
    if "centrifugal" in values and not isinstance(values["centrifugal"], bool):
        problems.append(f"centrifugal must be true or false, got {short_repr(values['centrifugal'])}")
    if "model" in values and values["model"] not in MODELS:
        problems.append(f"model: unknown model {short_repr(values['model'])}{suggestion(str(values['model']), MODELS)}; "
                        f"known models: {', '.join(MODELS)}")
    for key in TEXT_KEYS:
        if key in values and not isinstance(values[key], str):
            problems.append(f"{key} must be a string, got {short_repr(values[key])}")
    length, gravity = values.get("length_m"), values.get("gravity_m_s2", STANDARD_GRAVITY_M_S2)
    grid_keys_ok = not any(message.startswith(("duration_s", "output_interval_s", "length_m", "gravity_m_s2"))
                           for message in problems)
    if grid_keys_ok and "duration_s" in values and length is not None:
        period = 2.0 * math.pi * math.sqrt(length / gravity)  # PendulumParameters.small_swing_period_s
        interval = values.get("output_interval_s", default_output_interval(period, values["duration_s"]))
        problems += grid_problems(period, values["duration_s"], interval)
    return problems


def _toml_value(value: Any) -> str:
    """A default as a TOML file writes it (``true``, ``[0.0, 0.0]``, ``9.81``, a quoted text)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    if isinstance(value, str):
        return '"' + value.replace("{name}", "NAME") + '"'
    return repr(value)


def markdown_table() -> str:
    """The key table of bench/README.md "Scenes" (``|`` in a text escaped for Markdown)."""
    lines = ["| key | default | meaning |", "|---|---|---|"]
    for key in SCENE_KEY_TABLE:
        default = key.default_note or ("required without `base`" if key.default is None else f"`{_toml_value(key.default)}`")
        lines.append(f"| `{key.name}` | {default} | {key.meaning.replace('|', chr(92) + '|')} |")
    return "\n".join(lines)


if __name__ == "__main__":
    print(markdown_table())
