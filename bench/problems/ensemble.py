"""Ensembles: one scene table swept over its release and place, each member a scene with its own reference.

A scene table (``[scene.NAME]``, in a matrix file or a built-in scene file) may hold an ``ensemble`` table::

    [scene.lab_3m_azimuths]
    base = "lab_3m"
    [scene.lab_3m_azimuths.ensemble]
    release_azimuth_deg = {start = 0, stop = 180, step = 5}   # a range: start, start + step, …, up to stop
    latitude_deg = [30, 40.44]                                  # or a list of values

Each key is a swept field (``SWEPT_FIELDS``), each value a list of numbers or an inclusive range; the members
are every combination of the values (the fields in the table's order, the last varying fastest). A member is
the scene with the swept fields replaced, named ``NAME.LABEL`` (``member_label``: ``lab_3m_azimuths.az45``),
and checked like any scene (``bench.problems.scene_reader.read_scene``: a member outside what the models
describe, e.g. an amplitude beyond the length or a latitude beyond ±90°, is refused with its label).
``transverse_velocity_m_s`` is the release speed across the release direction (an elliptical release): the
initial velocity v·(−sin ψ, cos ψ) at release azimuth ψ, counter-clockwise seen from above for v > 0.

Range values are start + i·step rounded to ``RANGE_DIGITS`` significant digits, so that 0.1 + 2·0.1 is 0.3, the
number written, not 0.30000000000000004. A bad declaration gives one message per problem: an empty range or list,
an unknown field, a value listed twice, more than ``MAX_MEMBERS`` members, a member outside the models' limits.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from typing import Any, Callable, Mapping

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.scene import Scene
from foucault_bench.bench.validation import finite_number, short_repr, suggestion

ENSEMBLE_KEY = "ensemble"
"""The key of a scene table that holds its sweeps."""

SWEPT_FIELDS: dict[str, str] = {
    "release_azimuth_deg": "az",
    "amplitude_m": "amp",
    "latitude_deg": "lat",
    "transverse_velocity_m_s": "vt",
    "length_m": "len",
}
"""Field an ensemble may sweep → the prefix of its value in a member's name. All but
``transverse_velocity_m_s`` are scene keys (``bench.problems.scene_reader.SCENE_KEY_TABLE``)."""

RANGE_KEYS = ("start", "stop", "step")
RANGE_DIGITS = 12
"""Significant digits a range's values are rounded to (module docstring)."""
MAX_MEMBERS = 10_000
"""Most members one ensemble may have: each is a reference computation and a run per setting."""


def number_label(value: float) -> str:
    """A number as a scene name shows it: the shortest text that reads back as the same float (``repr``), with
    a whole number's ``.0`` and an exponent's ``+`` dropped (``45``, ``45.0000001``, ``1e20``, ``1e-05``).
    Distinct floats get distinct labels (``repr`` round-trips, and neither dropped piece can be confused with
    another float's text), unlike ``:g``, which keeps 6 digits: 45 and 45.0000001 were both ``45``."""
    return repr(float(value)).removesuffix(".0").replace("e+", "e")


def member_label(member: tuple[tuple[str, float], ...]) -> str:
    """The member's part of its name: each swept value (``number_label``) after its field's prefix, joined by
    ``_`` (``az45``, ``lat-90_amp0.3``)."""
    return "_".join(f"{SWEPT_FIELDS[field]}{number_label(value)}" for field, value in member)


def member_columns(scene: Scene, setting: str) -> tuple[tuple[str, Any], ...]:
    """The results columns that tag a member's rows (``bench.schema``): ``ensemble``, ``ensemble_member`` (a JSON
    object of the swept fields' values) and ``ensemble_setting`` (``setting``, the setting as the matrix asked
    for it); none for a scene outside an ensemble."""
    if not scene.ensemble:
        return ()
    return (("ensemble", scene.ensemble), ("ensemble_member", json.dumps(dict(scene.member))),
            ("ensemble_setting", setting))


def _values(field: str, value: Any, problem: Callable[[str], None]) -> list[float]:
    """The values of one sweep (a list or a ``{start, stop, step}`` range); one problem per fault."""
    if isinstance(value, dict):
        unknown = [key for key in value if key not in RANGE_KEYS]
        missing = [key for key in RANGE_KEYS if key not in value]
        if unknown or missing:
            problem(f"{field}: a range is a table of start, stop and step, got {short_repr(value)}")
            return []
        start, stop, step = (value[key] for key in RANGE_KEYS)
        if not all(finite_number(item) for item in (start, stop, step)):
            problem(f"{field}: start, stop and step must be finite numbers, got {short_repr(value)}")
            return []
        if step <= 0 or stop < start:
            problem(f"{field}: the range {short_repr(value)} is empty (it needs step > 0 and stop >= start)")
            return []
        count = math.floor((stop - start) / step * (1.0 + 1e-12)) + 1
        if count > MAX_MEMBERS:
            problem(f"{field}: the range has {count} values, more than the {MAX_MEMBERS} members an ensemble may have")
            return []
        return [float(f"{start + index * step:.{RANGE_DIGITS}g}") for index in range(count)]
    if not isinstance(value, list) or not value:
        problem(f"{field}: the sweep is empty: give a non-empty list of numbers or a range "
                f"{{start, stop, step}}, got {short_repr(value)}")
        return []
    bad = [item for item in value if not finite_number(item)]
    if bad:
        problem(f"{field}: every value must be a finite number, got {short_repr(bad[0])}")
        return []
    if len(set(value)) < len(value):
        problem(f"{field}: a value is listed more than once in {short_repr(value)}")
        return []
    return [float(item) for item in value]


def sweeps(table: Any, problem: Callable[[str], None]) -> list[tuple[str, list[float]]]:
    """The (field, values) pairs of an ``ensemble`` table, in its order; one problem per fault (module
    docstring). An empty result with no problem cannot happen: an empty table is a problem."""
    if not isinstance(table, dict) or not table:
        problem(f"the ensemble must be a non-empty table of sweeps (fields: {', '.join(SWEPT_FIELDS)}), "
                f"got {short_repr(table)}")
        return []
    found: list[tuple[str, list[float]]] = []
    for field, value in table.items():
        if field not in SWEPT_FIELDS:
            problem(f"unknown field {short_repr(field)}{suggestion(field, SWEPT_FIELDS)}; an ensemble may sweep "
                    f"{', '.join(SWEPT_FIELDS)}")
            continue
        values = _values(field, value, problem)
        if values:
            found.append((field, values))
    count = math.prod(len(values) for _, values in found)
    if count > MAX_MEMBERS:
        problem(f"the sweeps make {count} members, more than the {MAX_MEMBERS} an ensemble may have")
        return []
    return found


def read_members(name: str, mapping: Mapping[str, Any], read: Callable[[str, Mapping[str, Any]], Scene],
                 problem: Callable[[str], None]) -> list[Scene]:
    """The members of the scene table ``mapping`` (which holds an ``ensemble`` table), read one by one with
    ``read(name, table)`` (the scene reader); every problem goes to ``problem`` as one line. The table less its
    sweeps must itself be a valid scene: its problems are reported once, not once per member."""
    table = {key: value for key, value in mapping.items() if key != ENSEMBLE_KEY}
    faults: list[str] = []
    found = sweeps(mapping[ENSEMBLE_KEY], lambda message: faults.append(f"ensemble: {message}"))
    swept = {field for field, _ in found}
    if "transverse_velocity_m_s" in swept and "release_velocity_m_s" in table:
        faults.append("ensemble: transverse_velocity_m_s sets the release velocity; leave release_velocity_m_s out")
    try:
        centre = read(name, table)
    except InputError as error:
        faults += error.problems
    for message in faults:
        problem(message)
    if faults:
        return []
    members: list[Scene] = []
    for combination in itertools.product(*(values for _, values in found)):
        member = tuple(zip((field for field, _ in found), combination, strict=True))
        label = member_label(member)
        values = dict(member)
        speed = values.pop("transverse_velocity_m_s", None)
        changed = {**table, **values}
        if speed is not None:
            azimuth = math.radians(changed.get("release_azimuth_deg", centre.params.release_azimuth_deg))
            changed["release_velocity_m_s"] = [-speed * math.sin(azimuth), speed * math.cos(azimuth)]
        try:
            scene = read(f"{name}.{label}", changed)
        except InputError as error:
            for message in error.problems:
                problem(f"ensemble member {label}: {message}")
            continue
        members.append(dataclasses.replace(
            scene, title=f"{centre.title}, {label}", ensemble=name, member=member,
            assumptions=f"{centre.assumptions} Member {label} of the ensemble {name}.".strip()))
    return members
