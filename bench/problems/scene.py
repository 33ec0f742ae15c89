"""The scene type: a pendulum at a place, a model, a duration and one output grid shared by every integrator.

A scene fixes everything about a benchmark run except the integrator and its setting. This module says what a
scene is (``Scene``) and what it may be: its name (``scene_name_problem``), its output grid (``grid_problems``:
fine enough to locate every turning point, a whole number of intervals) and its physics
(``physical_limit_problems``: within what the models describe). ``bench.problems.scene_reader`` reads a scene
from a TOML table; ``bench.problems.scenes`` loads the built-in ones (``bench/scenes/*.toml``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.validation import finite_number, short_repr, suggestion
from foucault_bench.models import MODELS, Model, PendulumParameters, get_model

if TYPE_CHECKING:
    from foucault_bench.integrators import Problem

MIN_OUTPUT_INTERVALS_PER_PERIOD = 5.0
"""The output interval must be at most 1/5 of the small-swing period: turning points are located on the grid
(``bench.problems.turning_points.turning_points_from_grid``), which needs samples on both sides of each radius maximum
(strictly less than a quarter period; a fifth leaves a margin for the longer period of large swings)."""

MAX_OUTPUT_POINTS = 2_000_000
"""Largest output grid (points) a scene may ask for: 64 MB of float64 states per run."""

WHOLE_INTERVALS_RTOL = 1e-9
"""duration / output interval must be a whole number to this relative tolerance."""

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
        ensemble: the name of the ensemble the scene is a member of (``bench.problems.ensemble``); "" if none.
        member: the member's swept fields and their values, in the ensemble's order; () outside an ensemble.
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
    ensemble: str = ""
    member: tuple[tuple[str, float], ...] = ()

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
    ``NAME.spherical`` of ``bench.verdicts.adequacy``, names no file and may be longer)."""
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
      (``bench.problems.turning_points``), and the terms of relative size (Ω/k)² that the planar models drop
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
