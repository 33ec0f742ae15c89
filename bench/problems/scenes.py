"""Scenes: a pendulum at a place, a model, a duration and one output grid shared by every integrator.

A scene fixes everything about a benchmark run except the integrator and its setting. Built-in scenes are the
real pendulums of models/README.md "Real pendulums" plus an Airy scene and the seed note's own setting; a matrix
file may define more inline (``[scene.NAME]`` tables, read by ``scene_from_mapping``), optionally starting from
a built-in one (``base = "pantheon"``).

How the built-in scenes were chosen:

* **Model.** The simplest model of the hierarchy (models/README.md "The models": linear < seed's planar
  < spherical) that resolves the precession rate to the precision its source quotes it. The linear model neglects
  the Airy precession (3/8)θ₀² (θ₀ = A/L), the release-side term ≈ ¼θ₀³cot φ and the centrifugal anisotropy; a
  scene is linear when these stay well below the rounding of the quoted rate, spherical otherwise. Each scene's
  ``why_model`` gives its numbers; ``bench.problems.adequacy`` measures what the other models would change.
* **Amplitude.** Not well sourced for any real pendulum (models/README.md "Real pendulums"): each scene states
  the amplitude it assumes, a swing of θ₀ ≈ 0.045-0.05 rad unless the scene is about large swings.
* **Duration.** Cost grows with the number of swings, so each real scene lasts 200-520 small-swing periods
  (30 min to 1 h), enough for the swing plane to turn 4-15°; the default matrix (every integrator family
  over a work-precision sweep of every real scene) then stays within minutes on 2 cores, and the real128
  reference of a scene takes at most about 6 s (measured; ``bench.problems.reference``).
* **Output interval.** About an eighth of a small-swing period, chosen not to divide the half period exactly:
  fine enough to locate every turning point (``bench.verdicts`` needs less than a quarter period; this
  module enforces a fifth) with a measurement floor far below the physics, and coarse enough that fixed
  steps up to kh ≈ 0.8 fit (a fixed-step run's step is at most one output interval).
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.validation import finite_number, is_number, short_repr, suggestion
from foucault_bench.models import MODELS, SIDEREAL_EARTH_RATE_RAD_S, Model, PendulumParameters, get_model
from foucault_bench.models.parameters import STANDARD_GRAVITY_M_S2

if TYPE_CHECKING:
    from foucault_bench.integrators import Problem

MIN_OUTPUT_INTERVALS_PER_PERIOD = 5.0
"""The output interval must be at most 1/5 of the small-swing period: turning points are located on the grid
(``bench.verdicts.turning_points.turning_points_from_grid``), which needs samples on both sides of each radius maximum
(strictly less than a quarter period; a fifth leaves a margin for the longer period of large swings)."""

MAX_OUTPUT_POINTS = 2_000_000
"""Largest output grid (points) a scene may ask for: 64 MB of float64 states per run."""

WHOLE_INTERVALS_RTOL = 1e-9
"""duration / output interval must be a whole number to this relative tolerance."""

SEED_EARTH_RATE_RAD_S = 2.0 * math.pi / (24.0 * 3600.0)
"""The seed note's ω = 2π/24 h (its §2): the solar, not the sidereal, day; 0.27 % below Ω_E."""

SCENE_NAME_PATTERN = re.compile(r"[A-Za-z0-9_.-]+")
"""What a scene name may hold; matched with ``fullmatch`` (``match`` with ``$`` would let a final newline by)."""

MAX_SCENE_NAME_LENGTH = 64
"""Longest scene name (characters; ASCII by ``SCENE_NAME_PATTERN``, so also bytes). A report names files after
its scenes through ``reports.build.file_stem``, which writes a character as at most 2 (``A`` → ``-a``): 128
bytes, leaving 127 of the 255 that a file name may have on Linux (NAME_MAX of ext4, XFS, Btrfs, tmpfs), macOS
(APFS) and Windows (NTFS) for what the report adds around the stem. The longest such name today,
``work_precision_<stem>_precession_rate_ref_error.png``, adds 45 bytes (a 173-byte name at this limit), which
leaves 82 bytes for a longer prefix or suffix or a temporary file's decoration. tests/test_scenes.py builds a
report for a name of this length in capitals and checks every file name it writes."""


@dataclass(frozen=True)
class Scene:
    """One benchmark scene.

    Attributes:
        name: key (letters, digits, ``_ . -``), used in tables, file names and matrix files.
        title: one line for reports.
        model: model registry name (``models.MODELS``).
        params: the pendulum, place and release.
        duration_s: integrated time span (s), a whole number of output intervals.
        output_interval_s: spacing (s) of the uniform output grid 0, Δ, 2Δ, …, duration: the same grid for
            every integrator of the scene and for its reference.
        why_model: why ``model`` is enough for what the scene measures.
        source: where the numbers come from.
        assumptions: what the scene assumes where the sources say nothing (amplitude, duration, …).
    """

    name: str
    title: str
    model: str
    params: PendulumParameters
    duration_s: float
    output_interval_s: float
    why_model: str
    source: str
    assumptions: str = ""

    def __post_init__(self) -> None:
        problems = grid_problems(self.params.small_swing_period_s, self.duration_s, self.output_interval_s)
        problems += physical_limit_problems(self.params)
        name_problem = scene_name_problem(self.name, max_length=None)  # the length: a matrix's rule (see there)
        if name_problem:
            problems.insert(0, name_problem)
        if self.model not in MODELS:
            problems.insert(0, f"model: unknown model {short_repr(self.model)}{suggestion(self.model, MODELS)}; "
                               f"known models: {', '.join(MODELS)}")
        if problems:
            raise InputError(problems)

    @property
    def model_object(self) -> Model:
        return get_model(self.model)

    @property
    def n_intervals(self) -> int:
        return round(self.duration_s / self.output_interval_s)

    def output_grid(self) -> np.ndarray:
        """Output times (s): Δ·(0, 1, …, n), exact multiples of the interval Δ, ending at the duration."""
        return self.output_interval_s * np.arange(self.n_intervals + 1, dtype=np.float64)

    def problem(self) -> Problem:
        """The integration problem: model, parameters and the scene's output grid."""
        from foucault_bench.integrators import Problem  # here: reading scenes needs no integrator

        return Problem(model=self.model_object, params=self.params, t_out=self.output_grid())


def scene_name_problem(name: Any, max_length: int | None = MAX_SCENE_NAME_LENGTH) -> str | None:
    """Why ``name`` cannot name a scene, or ``None``: its characters (``SCENE_NAME_PATTERN``, every scene) and
    its length (``max_length``; ``bench.run.matrix`` holds every scene a matrix runs to
    ``MAX_SCENE_NAME_LENGTH``, while a scene made inside a computation, such as the model variants
    ``NAME.spherical`` of ``bench.problems.adequacy``, names no file and may be longer)."""
    if not isinstance(name, str) or not SCENE_NAME_PATTERN.fullmatch(name):
        return f"scene name {short_repr(name)} may hold only letters, digits, '_', '.' and '-'"
    if max_length is not None and len(name) > max_length:
        return (f"scene name {short_repr(name)} has {len(name)} characters, more than {MAX_SCENE_NAME_LENGTH}: the "
                "report's file names, made from it, must fit the 255 bytes a file name may have")
    return None


def physical_limit_problems(params: PendulumParameters) -> list[str]:
    """What puts a pendulum outside what the models describe (empty list: nothing). Two limits:

    * **Earth's rate below the pendulum's frequency**, Ω < k = √(g/L). The rotating-frame models describe a swing
      whose plane Earth turns slowly: by π Ω sin φ / k per swing. At Ω ≥ k that is up to half a turn or more per
      swing, so there is no swing plane whose turning points the precession measurement could follow
      (``bench.verdicts.turning_points``), and the terms of relative size (Ω/k)² that the planar models drop
      (models/README.md "The models") are of order one. Earth's Ω_E/k is 10⁻⁵-10⁻⁴ for real pendulums.
    * **The bob stays below the pivot's height.** The spherical model's coordinates end there (z = −√(L² − x²
      − y²), ``models.spherical``), a string can go slack above it, and the planar models approximate the
      spherical one. The spherical model conserves its Jacobi integral h = ½|ṙ|² + g z − (c/2)|ω×r|² exactly;
      at z = 0 (the pivot's height) h ≥ −(c/2)|ω|²L², since |ω×r| ≤ |ω| L. So a release with h₀ < −(c/2)|ω|²L²
      can never reach that height: this is required of every release (from rest it holds unless Ω is near k
      and the amplitude near L). For a release speed s along a direction û, h₀ = ½ s² q + h₀(s = 0) with
      q = 1 + ((x₀û_x + y₀û_y)/z₀)² (ż₀ = −(x₀ẋ₀ + y₀ẏ₀)/z₀), which gives the largest speed in the message.
    """
    from foucault_bench.models.spherical import energy as jacobi_integral  # (m, x, y, vx, vy, parameters)

    k = params.pendulum_frequency_rad_s
    omega = params.earth_rate_rad_s
    if omega >= k:
        return [f"earth_rate_rad_s = {omega:.6g} rad/s must be below the pendulum's own frequency k = √(g/L) = "
                f"{k:.6g} rad/s: at Ω ≥ k Earth turns the swing plane by up to half a turn or more per swing, so "
                "there is no swing plane to follow and the models' neglected (Ω/k)² terms are of order one"]
    x0, y0, vx, vy = (float(value) for value in params.initial_state())
    vector = params.parameter_vector()
    centrifugal = 1.0 if params.centrifugal else 0.0
    least_at_pivot_height = -0.5 * centrifugal * omega**2 * params.length_m**2
    at_rest = jacobi_integral(math, x0, y0, 0.0, 0.0, vector) - least_at_pivot_height
    speed = math.hypot(vx, vy)
    if speed == 0.0:
        if at_rest < 0.0:
            return []
        return [f"released at amplitude_m = {short_repr(params.amplitude_m)} m with earth_rate_rad_s = {omega:.6g} rad/s "
                f"(k = {k:.6g} rad/s) the bob can rise to the pivot's height even from rest, where the models end "
                "(lower the amplitude or the rate)"]
    z0 = -math.sqrt(params.length_m**2 - x0**2 - y0**2)
    q = 1.0 + ((x0 * vx / speed + y0 * vy / speed) / z0) ** 2
    largest = math.sqrt(-2.0 * at_rest / q) if at_rest < 0.0 else 0.0
    if speed < largest:
        return []
    return [f"release_velocity_m_s = {short_repr(list(params.release_velocity_m_s))}: a release speed of "
            f"{speed:.6g} m/s lifts the bob to the pivot's height, where the models end (the spherical model's "
            f"Jacobi integral would exceed −(c/2)|ω|²L², its least value there); from this release point in this "
            f"direction the speed must stay below {largest:.6g} m/s"]


def grid_problems(period_s: float, duration_s: float, output_interval_s: float) -> list[str]:
    """What is wrong with a duration and output interval for a pendulum of small-swing period ``period_s``
    (empty list: nothing)."""
    problems: list[str] = []
    if not (finite_number(duration_s, positive=True)):
        problems.append(f"duration_s must be a number of seconds > 0, got {short_repr(duration_s)}")
    if not (finite_number(output_interval_s, positive=True)):
        problems.append(f"output_interval_s must be a number of seconds > 0, got {short_repr(output_interval_s)}")
    if problems:
        return problems
    period = period_s
    if output_interval_s > period / MIN_OUTPUT_INTERVALS_PER_PERIOD:
        problems.append(
            f"output_interval_s = {output_interval_s:g} s is too coarse to locate the turning points: at most "
            f"1/{MIN_OUTPUT_INTERVALS_PER_PERIOD:g} of the small-swing period {period:.4g} s, i.e. "
            f"{period / MIN_OUTPUT_INTERVALS_PER_PERIOD:.4g} s (about 1/8 of a period is usual)"
        )
    ratio = duration_s / output_interval_s
    whole = round(ratio)
    if whole < 1 or abs(ratio - whole) > WHOLE_INTERVALS_RTOL * ratio:
        below, above = math.floor(ratio), math.ceil(ratio)
        options = [f"{n * output_interval_s:.10g}" for n in (below, above) if n >= 1]
        problems.append(
            f"duration_s = {duration_s:g} s is not a whole number of output intervals ({output_interval_s:g} s); "
            f"use {' or '.join(options)} s"
        )
    elif whole + 1 > MAX_OUTPUT_POINTS:
        problems.append(
            f"the output grid would hold {whole + 1} points (duration_s / output_interval_s + 1), more than "
            f"{MAX_OUTPUT_POINTS}: shorten the scene or widen the interval"
        )
    return problems


# --- inline scenes ---------------------------------------------------------------------------------------------


PARAMETER_KEYS = tuple(field.name for field in dataclasses.fields(PendulumParameters))
TEXT_KEYS = ("title", "why_model", "source", "assumptions")
SCENE_KEYS = ("base", "model", "duration_s", "output_interval_s") + PARAMETER_KEYS + TEXT_KEYS
REQUIRED_KEYS = ("model", "length_m", "latitude_deg", "amplitude_m", "duration_s")
DEFAULT_PERIOD_FRACTION = 8
"""Without ``output_interval_s``, an inline scene samples about an eighth of the small-swing period."""


def default_output_interval(period_s: float, duration_s: float) -> float:
    """The largest interval (s) of at most period/8 that divides ``duration_s`` into whole intervals."""
    return duration_s / math.ceil(DEFAULT_PERIOD_FRACTION * duration_s / period_s)


def scene_from_mapping(name: str, mapping: Mapping[str, Any]) -> Scene:
    """A scene from a matrix file's ``[scene.NAME]`` table; ``InputError`` lists every problem at once.

    Keys: ``model``, ``duration_s``, ``output_interval_s`` (default: ``default_output_interval``), the
    ``PendulumParameters`` fields (``length_m``, ``latitude_deg``, ``amplitude_m``, ``gravity_m_s2``, ``earth_rate_rad_s``,
    ``release_azimuth_deg``, ``release_velocity_m_s`` = [vx, vy], ``centrifugal``) and the texts ``title``,
    ``why_model``, ``source``, ``assumptions``. ``base = "NAME"`` starts from a built-in scene, so that only
    the changed fields need to be given; without it ``model``, ``length_m``, ``latitude_deg``, ``amplitude_m``
    and ``duration_s`` are required.
    """
    problems: list[str] = []
    if not isinstance(mapping, Mapping):
        raise InputError([f"a scene must be a table of fields, got {short_repr(mapping)}"])
    for key in mapping:
        if key not in SCENE_KEYS:
            problems.append(f"unknown key {short_repr(key)}{suggestion(str(key), SCENE_KEYS)}; "
                            f"known keys: {', '.join(SCENE_KEYS)}")
    values: dict[str, Any] = {}
    base_name = mapping.get("base")
    if base_name is not None:
        if isinstance(base_name, str) and base_name in SCENES:
            base = SCENES[base_name]
            values.update(dataclasses.asdict(base.params))
            values.update(model=base.model, duration_s=base.duration_s, output_interval_s=base.output_interval_s,
                          title=f"{base.title} (variant {name})", source=base.source,
                          why_model=f"inherited from the built-in scene {base_name!r} (check that it still holds "
                                    f"for the changed fields): {base.why_model}",
                          assumptions=base.assumptions)
        else:
            problems.append(f"base: unknown scene {short_repr(base_name)}{suggestion(str(base_name), SCENES)}; "
                            f"built-in scenes: {', '.join(SCENES)}")
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
    return Scene(
        name=name,
        title=values.get("title", f"inline scene {name}"),
        model=values["model"],
        params=params,
        duration_s=duration,
        output_interval_s=float(values.get("output_interval_s",
                                           default_output_interval(params.small_swing_period_s, duration))),
        why_model=values.get("why_model", "chosen by the matrix file"),
        source=values.get("source", "inline scene of a matrix file"),
        assumptions=values.get("assumptions", ""),
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


# --- the built-in scenes -----------------------------------------------------------------------------------------


def _linear_why(theta0: float, quoted: str, quoted_rounding: float, latitude_deg: float, length_m: float) -> str:
    k = math.sqrt(STANDARD_GRAVITY_M_S2 / length_m)
    airy = 0.375 * theta0**2
    release_side = 0.25 * theta0**3 / abs(math.tan(math.radians(latitude_deg)))
    return (
        f"The scene measures the swing plane's rate, quoted as {quoted} (rounding ±{quoted_rounding:.1e} relative). "
        f"The linear model (seed eqs. 6-7) turns the plane at exactly −Ω_E sin φ; what it leaves out at θ₀ = "
        f"{theta0:.4f} is the Airy precession (3/8)θ₀² = {airy:.1e}, the release-side term ≲ ¼θ₀³cot φ = "
        f"{release_side:.0e} and the centrifugal anisotropy (≈ (Ω_E/k)² = {(SIDEREAL_EARTH_RATE_RAD_S / k) ** 2:.1e}), "
        f"all below the quoted rounding, so the spherical model would not change the figure the scene is about (bench.problems.adequacy "
        f"reports the trajectory it does change: the finite-amplitude period)."
    )


def _spherical_why(theta0: float, quoted: str, quoted_rounding: float) -> str:
    airy = 0.375 * theta0**2
    return (
        f"The scene measures the swing plane's rate, quoted as {quoted} (rounding ±{quoted_rounding:.1e} relative). "
        f"At θ₀ = {theta0:.4f} the Airy precession (3/8)θ₀² = {airy:.1e} of the rate exceeds that rounding, so "
        f"the planar models (which turn the plane at −Ω_E sin φ, or, for the seed's eqs. 4-5, with a term "
        f"~100× smaller than the geometric nonlinearity it drops) cannot resolve it: the spherical pendulum in "
        f"the rotating frame with the full ω is the simplest model that does."
    )


def _builtin_scenes() -> dict[str, Scene]:
    scenes = [
        Scene(
            name="pantheon",
            title="Panthéon, Paris 1851 (67 m, 48.846° N)",
            model="linear",
            params=PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0),
            duration_s=3600.0,
            output_interval_s=2.0,
            why_model=_linear_why(3.0 / 67.0, "11.3°/h clockwise", 0.05 / 11.3, 48.846, 67.0),
            source="Foucault, C. R. Acad. Sci. Paris 32, 135 (1851); Aczel, Pendulum (2003): the Panthéon pendulum: "
                   "L = 67 m, 28 kg bob, period 16.4 s, 11.3°/h clockwise.",
            assumptions="amplitude 3 m (the figure commonly given); released from rest towards the East; "
                        "1 h (219 periods, the plane turns 11.3°); output every 2 s (≈ period/8.2).",
        ),
        Scene(
            name="un_headquarters",
            title="UN headquarters, New York (22.9 m, 40.749° N)",
            model="linear",
            params=PendulumParameters(length_m=22.9, latitude_deg=40.749, amplitude_m=1.0),
            duration_s=3600.0,
            output_interval_s=1.25,
            why_model=_linear_why(1.0 / 22.9, "9.8°/h clockwise", 0.05 / 9.8, 40.749, 22.9),
            source="United Nations gift record UNNY134G (Foucault Pendulum, 1955): wire 75 ft = 22.9 m, "
                   "200 lb = 91 kg bob; period 9.6 s, "
                   "9.8°/h clockwise.",
            assumptions="amplitude 1 m (θ₀ ≈ 0.044, not sourced); released from rest towards the East; 1 h "
                        "(375 periods); output every 1.25 s (≈ period/7.7).",
        ),
        Scene(
            name="griffith",
            title="Griffith Observatory, Los Angeles (12.2 m, 34.118° N)",
            model="linear",
            params=PendulumParameters(length_m=12.2, latitude_deg=34.118, amplitude_m=0.6),
            duration_s=1800.0,
            output_interval_s=0.9,
            why_model=_linear_why(0.6 / 12.2, "8.4°/h clockwise", 0.05 / 8.4, 34.118, 12.2),
            source="Griffith Observatory exhibit description: cable 40 ft = 12.2 m, 240 lb = 109 kg bob; "
                   "period 7.0 s, 8.4°/h clockwise.",
            assumptions="amplitude 0.6 m (θ₀ ≈ 0.049, not sourced); released from rest towards the East; "
                        "30 min (257 periods, the plane turns 4.2°); output every 0.9 s (≈ period/7.8).",
        ),
        Scene(
            name="south_pole",
            title="Amundsen-Scott South Pole station (33 m, 90° S)",
            model="spherical",
            params=PendulumParameters(length_m=33.0, latitude_deg=-90.0, amplitude_m=1.5),
            duration_s=3600.0,
            output_interval_s=1.5,
            why_model=_spherical_why(1.5 / 33.0, "15.04°/h counter-clockwise", 0.005 / 15.04)
            + " At the pole ω is vertical: no release-side term, the Airy correction appears alone.",
            source="Baker, Seven Tales of the Pendulum (OUP 2011), Tale 1: Amundsen-Scott South Pole station "
                   "(2001): L = 33 m, 25 kg bob, "
                   "period 11.5 s, 15.04°/h counter-clockwise.",
            assumptions="amplitude 1.5 m (θ₀ ≈ 0.045, not sourced); released from rest along azimuth 90°; "
                        "1 h (313 periods, the plane turns 15°); output every 1.5 s (≈ period/7.7).",
        ),
        Scene(
            name="lab_3m",
            title="3 m laboratory pendulum (arXiv:0902.1829, 40.44° N)",
            model="spherical",
            params=PendulumParameters(length_m=3.0, latitude_deg=40.44, amplitude_m=0.15),
            duration_s=1800.0,
            output_interval_s=0.45,
            why_model=_spherical_why(0.15 / 3.0, "9.76°/h clockwise", 0.005 / 9.76),
            source="Schumacher & Tarbet, arXiv:0902.1829 (2009): L = 3 m, period 3.47 s, latitude 40.44° N, "
                   "9.76°/h clockwise.",
            assumptions="amplitude 0.15 m (θ₀ = 0.05, not sourced); released from rest towards the East; 30 min "
                        "(518 periods, the plane turns 4.9°); output every 0.45 s (≈ period/7.7).",
        ),
        Scene(
            name="airy_3m",
            title="Airy precession: the 3 m pendulum at a 0.9 m swing (θ₀ = 0.3)",
            model="spherical",
            params=PendulumParameters(length_m=3.0, latitude_deg=40.44, amplitude_m=0.9),
            duration_s=1800.0,
            output_interval_s=0.45,
            why_model="The scene measures how a large swing's plane departs from −Ω_E sin φ: the Airy precession "
                      "of the Coriolis-made ellipse, −Ω_E sin φ·(1 − (3/8)θ₀²), 3.4 % slower at θ₀ = 0.3 "
                      "(Airy 1851; Olsson, Am. J. Phys. 49, 531, 1981). Only the spherical model has it: both "
                      "planar models lack the geometric nonlinearity that makes it.",
            source="Airy, Mem. R. Astron. Soc. 20, 121 (1851); pendulum of Schumacher & Tarbet, arXiv:0902.1829 "
                   "(L = 3 m, 40.44° N).",
            assumptions="amplitude 0.9 m (θ₀ = 0.3, a deliberately large swing); released from rest towards the "
                        "East, where the release-side term (∝ cos of the release azimuth from South) vanishes; "
                        "30 min (≈ 516 periods); output every 0.45 s.",
        ),
        Scene(
            name="lab_3m_ns",
            title="3 m laboratory pendulum released North-South (40.44° N)",
            model="spherical",
            params=PendulumParameters(length_m=3.0, latitude_deg=40.44, amplitude_m=0.15, release_azimuth_deg=0.0),
            duration_s=1800.0,
            output_interval_s=0.45,
            why_model=_spherical_why(0.15 / 3.0, "9.76°/h clockwise", 0.005 / 9.76)
            + " Released towards the South, the swing feels the horizontal part of ω along its own line: the "
              "release-side term ≈ ¼θ₀³ cot φ cos ψ, absent for an East release, is largest here, and only the "
              "spherical model has it.",
            source="arXiv:0902.1829: L = 3 m, period 3.47 s, 40.44° N, 9.76°/h clockwise; the release direction "
                   "is this scene's.",
            assumptions="amplitude 0.15 m (θ₀ = 0.05, not sourced); released from rest towards the South "
                        "(azimuth 0°), where integrators whose error depends on the direction of the swing "
                        "relative to ω show it (an East release hides it); 30 min; output every 0.45 s.",
        ),
        Scene(
            name="quito_3m_ns",
            title="3 m pendulum at Quito's latitude (0.18° S), released North-South",
            model="spherical",
            params=PendulumParameters(length_m=3.0, latitude_deg=-0.18, amplitude_m=0.15, release_azimuth_deg=0.0),
            duration_s=1800.0,
            output_interval_s=0.45,
            why_model="Near the equator the vertical rate Ω_E sin φ nearly vanishes (0.047°/h here) while the "
                      "horizontal part of ω is almost all of Ω_E: what turns the swing is dominated by terms the "
                      "planar models do not have (the release-side term, the Airy precession of a Coriolis-made "
                      "ellipse). Only the spherical model with the full ω has them.",
            source="hypothetical: the 3 m pendulum of arXiv:0902.1829 moved to the latitude of Quito, Ecuador "
                   "(about 0.18° S).",
            assumptions="amplitude 0.15 m (θ₀ = 0.05); released from rest towards the South (azimuth 0°); no "
                        "sourced pendulum swings here: the scene shows what rate errors relative to the local "
                        "rate do near the equator (use precession errors relative to Ω_E to compare scenes); "
                        "30 min; output every 0.45 s.",
        ),
        Scene(
            name="seed_2min",
            title="The seed note's setting: the first 2 minutes, ω = 2π/24 h (linear model)",
            model="linear",
            params=PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=0.5,
                                      earth_rate_rad_s=SEED_EARTH_RATE_RAD_S),
            duration_s=120.0,
            output_interval_s=2.0,
            why_model="The seed solves its linearised eqs. (6)-(7) and plots the first 2 minutes against its "
                      "approximate solution (14)-(15); the scene reproduces exactly that setting, so it uses the "
                      "same linear model and the seed's own ω = 2π/24 h (0.27 % below the sidereal Ω_E).",
            source="Seed note §3 (eqs. 6-7, 14-15: 'los primeros 2 mins') and §2 (ω = 2π/24 h = 7.3e-5 rad/s).",
            assumptions="the seed states no length, latitude or amplitude ('datos realistas'): assumed the "
                        "Panthéon's L = 67 m at 48.846° N with y₀ = 0.5 m, released from rest at x = 0, y = y₀ as "
                        f"in the seed, which makes the North-South drift x (x points South) reach ≈ 3 mm in 2 min (the "
                        f"seed: 'del orden de milímetros'); sidereal Ω_E would be {SIDEREAL_EARTH_RATE_RAD_S:.7e} "
                        "rad/s. The command `foucault-bench seed`, which redraws the note's own figures, assumes "
                        "L = 10 m at 45° instead (reports.studies.SeedConfig): there its "
                        "Euler run's failure shows within the 2 minutes; this scene puts the note's question on a "
                        "documented pendulum, like every other scene, and the drift scale y₀ω t cos λ is the same "
                        "3 mm in both.",
        ),
    ]
    return {scene.name: scene for scene in scenes}


SCENES: dict[str, Scene] = _builtin_scenes()
"""The built-in scenes by name (insertion order: the order reports list them)."""

SCENE_FILES_DIRECTORY = Path(__file__).resolve().parents[1] / "scenes"
"""Built-in scenes written as TOML files (``bench/scenes/NAME.toml``, ``[scene.NAME]`` tables)."""


def scenes_from_file(path: Path) -> dict[str, Scene]:
    """The ``[scene.NAME]`` tables of a TOML file, each read by ``scene_from_mapping`` (other tables ignored)."""
    with open(path, "rb") as handle:
        tables = tomllib.load(handle).get("scene", {})
    return {name: scene_from_mapping(name, mapping) for name, mapping in tables.items()}


SCENES.update(scenes_from_file(SCENE_FILES_DIRECTORY / "real_halls.toml"))
