"""Studies behind the report's study charts: plain computations that return tidy pandas DataFrames.

Each study is one function of a frozen config dataclass (sizes are fields, so a test can run a small one) and
returns a DataFrame; ``reports`` only reads and plots these frames. ``STUDIES`` maps a study's name (also the
name of its table in the results database) to its function and default config; ``ensure_studies`` reads the
stored tables and computes the missing ones.

* ``long_time_energy``: relative energy error against time for one representative per integrator family
  (``family_representatives``); ``energy_trends`` says from the table which errors stay bounded, drift or grow.
* ``stability_sweep``: long runs and the one-step map's growth against k·h for every fixed-step integrator,
  with and without Earth's rotation: the measured stability limit beside the declared one, and the growth per
  step where rotation destabilises a method (symplectic Euler) beside its theory.
* ``precession_vs_latitude``: the swing plane's measured rate for many latitudes at once (one heyoka
  ``taylor_adaptive_batch``, one batch element per latitude), against −Ω_E sin φ and its Airy correction.
* ``precession_vs_release_azimuth``: the precession error of each fixed-step integrator declaring a
  volume-preserving one-step map (``structure_preserving_integrators``) against the direction of release, at a
  mid-latitude and near the equator (an East release hides what a North-South one shows), at the step each
  run took; ``midpoint_precession_law`` sets the implicit midpoint rule's error beside its (kh)²/4 law.
* ``seed_revisited``: the numbers behind the seed note's figures and their corrections (``reports.seed``).

All runs go through the suite's own models and integrator registry; nothing here re-implements an equation of
motion or an integrator.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Callable, Protocol, cast

import numpy as np
import pandas as pd
from tqdm import tqdm

from foucault_bench.bench.problems.reference import REFERENCE_INTEGRATOR
from foucault_bench.bench.problems.scenes import SEED_EARTH_RATE_RAD_S
from foucault_bench.bench.schema import setting_label
from foucault_bench.bench.verdicts.columns import energy_scale, energy_verdicts, released_from_rest
from foucault_bench.bench.verdicts.stability import measured_stability_limit, spectral_growth, step_matrix
from foucault_bench.bench.problems.turning_points import grid_accelerations, precession_rate, turning_points_from_grid
from foucault_bench.integrators import (
    STATUS_DIVERGED,
    STATUS_OK,
    FixedStepIntegrator,
    Problem,
    Solution,
    get_integrator,
)
from foucault_bench.integrators.base import COST_COMPILED
from foucault_bench.integrators.registry import REGISTRY, built_in_names
from foucault_bench.models import Model, PendulumParameters, get_model
from foucault_bench.models.analytic import linear_exact, seed_approximate, seed_gap_bound
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S, STANDARD_GRAVITY_M_S2


# --------------------------------------------------------------------------------------------------------------
# shared helpers
# --------------------------------------------------------------------------------------------------------------
def relative_energy_error(model: Model, params: PendulumParameters, states: np.ndarray) -> np.ndarray:
    """(E(t) − E₀) / E_swing on the rows of ``states`` (columns x, y, ẋ, ẏ), with E₀ and E_swing from
    ``bench.verdicts.columns.energy_scale`` (the normalisation of the results table) and E from the model's own energy
    source evaluated with numpy (``models.base``: the same source the compiled code uses)."""
    energy0, swing = energy_scale(model, params)
    energy = model.energy(np, states[:, 0], states[:, 1], states[:, 2], states[:, 3], params.parameter_vector())
    return (energy - energy0) / swing


def solve_with_setting(integrator_name: str, problem: Problem, setting: float) -> Solution:
    """Run a registered integrator with ``setting`` read as k·h for fixed-step methods (step = setting / k)
    and as the tolerance for adaptive ones. An unknown integrator becomes a failed solution, not a crash."""
    try:
        integrator = get_integrator(integrator_name)
    except KeyError as error:
        return Solution.failure(problem.t_out, str(error.args[0]))
    if integrator.adaptive:
        return integrator.solve(problem, tol=setting)
    return integrator.solve(problem, step_s=setting / problem.params.pendulum_frequency_rad_s)


def study_setting_label(integrator_name: str, setting: float) -> str:
    """The results store's label ('kh=0.1' or 'tol=1e-12') for a study run's setting."""
    integrator = REGISTRY.get(integrator_name)
    if integrator is not None and not integrator.adaptive:
        return setting_label(setting, None)
    return setting_label(None, setting)


def family_of(integrator_name: str) -> str:
    integrator = REGISTRY.get(integrator_name)
    return integrator.family if integrator is not None else "unknown"


def _progress(items: list, description: str, show: bool):
    return tqdm(items, desc=description, unit="run", disable=not show, leave=False)


# --------------------------------------------------------------------------------------------------------------
# long-time energy
# --------------------------------------------------------------------------------------------------------------
def family_representatives() -> dict[str, str]:
    """One built-in integrator per family present in the registry (family → name), chosen from the facts each
    declares (``integrators.base.Integrator``), so that a new family appears on its own: a family's simplest
    member, i.e. fixed-step before adaptive, then the lowest declared order (a variable order counts as the
    highest), then compiled before Python-driven (``cost_basis``), then the first name; the reference
    integrator (``bench.problems.reference.REFERENCE_INTEGRATOR``, quad precision, not swept) comes last."""
    def simplicity(name: str) -> tuple:
        integrator = REGISTRY[name]
        order = math.inf if integrator.order is None else integrator.order
        return (name == REFERENCE_INTEGRATOR, integrator.adaptive, order, integrator.cost_basis != COST_COMPILED, name)

    chosen: dict[str, str] = {}
    for name in sorted(built_in_names(), key=simplicity):
        chosen.setdefault(REGISTRY[name].family, name)
    return dict(sorted(chosen.items()))


@dataclass(frozen=True)
class LongTimeEnergyConfig:
    """One pendulum integrated for a long time by one representative per family.

    ``runs`` pairs an integrator name with its setting (k·h for fixed-step, tolerance for adaptive); ``None``
    (the default) runs ``family_representatives()``, the fixed-step ones at k·h = ``kh`` and the adaptive ones
    at tolerance ``tol``. Default: the Panthéon (L = 67 m, φ = 48.846°, A = 3 m) on the spherical model for
    6 h (1317 swings).
    """

    model: str = "spherical"
    length_m: float = 67.0
    latitude_deg: float = 48.846
    amplitude_m: float = 3.0
    duration_s: float = 21600.0
    n_out: int = 4001
    kh: float = 0.05
    tol: float = 1e-12
    runs: tuple[tuple[str, float], ...] | None = None

    def chosen_runs(self) -> tuple[tuple[str, float], ...]:
        """``runs``, or one representative per family at ``kh`` or ``tol``."""
        if self.runs is not None:
            return self.runs
        return tuple((name, self.tol if REGISTRY[name].adaptive else self.kh)
                     for name in family_representatives().values())


def long_time_energy(config: LongTimeEnergyConfig = LongTimeEnergyConfig(), progress: bool = True) -> pd.DataFrame:
    """Relative energy error (E − E₀)/E_swing (``relative_energy_error``) on a uniform output grid (t > 0) for
    each run of ``config.chosen_runs()``.

    Columns: integrator, family, setting, status, message, t_s, energy_rel_error, plus the config's scalars.
    Rows after a divergence carry NaN errors; a failed run keeps one row per output time, all NaN.
    """
    model = get_model(config.model)
    params = PendulumParameters(length_m=config.length_m, latitude_deg=config.latitude_deg,
                                amplitude_m=config.amplitude_m)
    t_out = np.linspace(0.0, config.duration_s, config.n_out)
    problem = Problem(model=model, params=params, t_out=t_out)
    frames = []
    for name, setting in _progress(list(config.chosen_runs()), "long-time energy", progress):
        solution = solve_with_setting(name, problem, setting)
        frames.append(pd.DataFrame({
            "integrator": name,
            "family": family_of(name),
            "setting": study_setting_label(name, setting),
            "status": solution.status,
            "message": solution.message,
            "t_s": t_out[1:],
            "energy_rel_error": relative_energy_error(model, params, solution.y)[1:],
        }))
    frame = pd.concat(frames, ignore_index=True)
    return _with_config_columns(frame, config, exclude=("runs",))


BOUNDED_BELOW_EXPONENT = 0.25
"""An energy error whose running maximum grows slower than t^0.25 counts as bounded: nearer to a filled band's
t⁰ than to the t^0.5 of a random walk of round-off errors (Brouwer 1937), the slowest drift."""
GROWING_ABOVE_EXPONENT = 2.0
"""Faster than t² counts as growing (a linear drift is t¹; an exponential growth steepens without bound)."""


def early_horizon_s(duration_s: float) -> float:
    """The "first hour" of ``energy_trends``: 1 h, or half the run when it is shorter than 2 h."""
    return min(3600.0, duration_s / 2.0)


def energy_trends(energy: pd.DataFrame) -> pd.DataFrame:
    """Per run of a ``long_time_energy`` table: how its relative energy error behaves.

    M(t) is the largest |error| up to t. Columns: integrator, family, setting, status; early_horizon_s
    (``early_horizon_s`` of the run's duration); early_max_error M(early_horizon_s); max_error M at the last
    finite output (NaN when there is none); last_finite_s that time; exponent p of a least-squares fit
    log M = p log t + c over the finite outputs from early_horizon_s on (M floored at the double-precision unit
    round-off; NaN with fewer than two such outputs); trend: ``diverged`` or ``failed`` after the status,
    else ``bounded`` (p < ``BOUNDED_BELOW_EXPONENT``), ``growing`` (p > ``GROWING_ABOVE_EXPONENT``) or
    ``drifting``."""
    rows = []
    horizon_s = early_horizon_s(float(energy["config_duration_s"].iloc[0]))
    for (integrator, setting), run in energy.groupby(["integrator", "setting"], sort=False):
        run = run.sort_values("t_s")
        error = run["energy_rel_error"].abs().to_numpy(dtype=float)
        t_s = run["t_s"].to_numpy(dtype=float)
        finite = np.isfinite(error)
        running_max = np.maximum.accumulate(np.maximum(error[finite], np.finfo(float).eps))
        times = t_s[finite]
        late = times >= horizon_s
        exponent = (float(np.polyfit(np.log(times[late]), np.log(running_max[late]), 1)[0])
                    if np.count_nonzero(late) >= 2 else math.nan)
        status = run["status"].iloc[0]
        if status != STATUS_OK:
            trend = "diverged" if status == STATUS_DIVERGED else "failed"
        elif exponent < BOUNDED_BELOW_EXPONENT:
            trend = "bounded"
        elif exponent > GROWING_ABOVE_EXPONENT:
            trend = "growing"
        else:
            trend = "drifting"
        early = error[finite & (t_s <= horizon_s)]
        rows.append({
            "integrator": integrator, "family": run["family"].iloc[0], "setting": setting, "status": status,
            "early_horizon_s": horizon_s,
            "early_max_error": float(early.max()) if early.size else math.nan,
            "max_error": float(error[finite].max()) if finite.any() else math.nan,
            "last_finite_s": float(times[-1]) if times.size else math.nan,
            "exponent": exponent,
            "trend": trend,
        })
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------------------------------
# stability sweep
# --------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StabilitySweepConfig:
    """Every registered fixed-step integrator on the linear model at each k·h of ``kh``, without Earth's rotation
    (Ω_E = 0: the undamped oscillator that defines ``stability_limit_kh``) and with it (Ω_E sidereal at
    ``latitude_deg``).

    Two measurements per point: a long run of ``steps`` steps (its max energy error and whether it diverged),
    and the growth per step of the scheme's own one-step map (``bench.verdicts.stability``), from which the
    measured limit is bisected to ``limit_resolution_kh``.
    """

    model: str = "linear"
    length_m: float = 10.0
    latitude_deg: float = 48.846
    amplitude_m: float = 1.0
    steps: int = 20_000
    kh: tuple[float, ...] = (0.01, 0.02, 0.05, *np.round(np.linspace(0.1, 4.0, 40), 6))
    limit_resolution_kh: float = 1e-4


def stability_sweep(config: StabilitySweepConfig = StabilitySweepConfig(), progress: bool = True) -> pd.DataFrame:
    """Long runs and one-step growth across each fixed-step integrator's stability limit, with and without
    Earth's rotation.

    Columns: integrator, family, rotation (bool), rate_ratio (a/k with a = Ω_E sin φ; 0 without rotation),
    stability_limit_kh (declared, NaN when unstable for every h), measured_limit_kh (NaN when the step grows at
    every k·h of the grid), kh, steps_done, energy_max_rel_error (max |E − E₀|/E_swing over the run's steps, as
    in ``bench.verdicts.columns.energy_verdicts``), growth_per_step (measured: max |λ| − 1 of the one-step map),
    growth_theory (``Integrator.rotation_growth_per_step`` − 1 where the method declares one, else NaN),
    status, message, plus the config's scalars.
    """
    model = get_model(config.model)
    fixed_step = sorted(name for name, integrator in REGISTRY.items() if not integrator.adaptive)
    cases = [(name, rotation) for name in fixed_step for rotation in (False, True)]
    rows = []
    for name, rotation in _progress(cases, "stability sweep", progress):
        integrator = cast(FixedStepIntegrator, REGISTRY[name])  # not adaptive: the one-step map's interface
        params = PendulumParameters(length_m=config.length_m, latitude_deg=config.latitude_deg,
                                    amplitude_m=config.amplitude_m,
                                    earth_rate_rad_s=SIDEREAL_EARTH_RATE_RAD_S if rotation else 0.0)
        k = params.pendulum_frequency_rad_s
        rate_ratio = params.vertical_rate_rad_s / k
        measured = measured_stability_limit(integrator, params, np.asarray(config.kh), config.limit_resolution_kh)
        for kh in config.kh:
            step_s = float(kh) / k
            problem = Problem(model=model, params=params, t_out=np.linspace(0.0, config.steps * step_s, 11))
            solution = integrator.solve(problem, step_s=step_s)
            theory = integrator.rotation_growth_per_step(float(kh), rate_ratio) if rotation else None
            rows.append({
                "integrator": name,
                "family": integrator.family,
                "rotation": rotation,
                "rate_ratio": rate_ratio,
                "stability_limit_kh": np.nan if integrator.stability_limit_kh is None else integrator.stability_limit_kh,
                "measured_limit_kh": measured,
                "kh": float(kh),
                "steps_done": solution.steps,
                "energy_max_rel_error": energy_verdicts(model, params, solution)["energy_max_rel_error_steps"],
                "growth_per_step": spectral_growth(step_matrix(integrator, params, step_s)),
                "growth_theory": np.nan if theory is None else theory - 1.0,
                "status": solution.status,
                "message": solution.message,
            })
    return _with_config_columns(pd.DataFrame(rows), config, exclude=("kh",))


# --------------------------------------------------------------------------------------------------------------
# precession against latitude
# --------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PrecessionLatitudeConfig:
    """The Panthéon's pendulum (L = 67 m, A = 3 m) at ``n_latitudes`` latitudes from −90° to 90°, integrated
    for ``duration_s`` by one heyoka Taylor batch integrator at tolerance ``tol``."""

    model: str = "spherical"
    length_m: float = 67.0
    amplitude_m: float = 3.0
    duration_s: float = 3600.0
    n_latitudes: int = 37
    tol: float = 1e-15


def precession_vs_latitude(config: PrecessionLatitudeConfig = PrecessionLatitudeConfig(),
                           progress: bool = True) -> pd.DataFrame:
    """Measured swing-plane rate (rad/s, counter-clockwise about up positive) at each latitude.

    One ``heyoka.taylor_adaptive_batch`` carries all latitudes (batch element i has the parameter vector of
    latitude i); a non-terminal event on r·ṙ = 0 crossing downwards (a maximum of the radius) records each
    turning point from heyoka's dense output, and ``bench.problems.turning_points.precession_rate`` fits the rate
    (integrators/README.md "Measuring the precession rate"). Events at t = 0 (release from rest) are dropped, as in the
    fixed-step turning-point detector.

    Columns: latitude_deg, rate_rad_s, rate_stderr_rad_s, textbook_rate_rad_s (−Ω_E sin φ),
    airy_rate_rad_s (−Ω_E sin φ (1 − (3/8)θ₀²), θ₀ = A/L; Airy 1851, Olsson 1981, models/README.md "Airy precession"),
    turning_points, plus the config's scalars.
    """
    import heyoka

    model = get_model(config.model)
    latitudes = np.linspace(-90.0, 90.0, config.n_latitudes)
    params = [PendulumParameters(length_m=config.length_m, latitude_deg=float(lat), amplitude_m=config.amplitude_m)
              for lat in latitudes]
    state0 = np.ascontiguousarray(np.array([p.initial_state() for p in params]).T)
    pars = np.ascontiguousarray(model.heyoka_parameters(np.array([p.parameter_vector() for p in params])).T)
    turning: list[list[tuple[float, float, float]]] = [[] for _ in params]

    def record_turning_point(ta, time: float, direction_sign: int, batch_index: int) -> None:
        if time <= 0.0:
            return
        times = ta.time.copy()
        times[batch_index] = time
        ta.update_d_output(times)
        turning[batch_index].append((time, ta.d_output[0, batch_index], ta.d_output[1, batch_index]))

    x, y, vx, vy = heyoka.make_vars("x", "y", "vx", "vy")
    event = heyoka.nt_event_batch(x * vx + y * vy, record_turning_point,
                                  direction=heyoka.event_direction.negative)
    batch = heyoka.taylor_adaptive_batch(model.heyoka_system(), state0, pars=pars, tol=config.tol,
                                         nt_events=[event], compact_mode=True)
    chunks = np.linspace(0.0, config.duration_s, 11)[1:]
    for t_chunk in _progress(list(chunks), "precession vs latitude", progress):
        batch.propagate_until(float(t_chunk))
    rows = []
    for lat, p, points in zip(latitudes, params, turning, strict=True):
        rate, stderr = precession_rate(np.array(points, dtype=np.float64).reshape(-1, 3))
        rows.append({
            "latitude_deg": float(lat),
            "rate_rad_s": rate,
            "rate_stderr_rad_s": stderr,
            "textbook_rate_rad_s": p.textbook_precession_rate_rad_s,
            "airy_rate_rad_s": p.airy_precession_rate_rad_s,
            "turning_points": len(points),
        })
    return _with_config_columns(pd.DataFrame(rows), config, exclude=())


# --------------------------------------------------------------------------------------------------------------
# precession error against the release azimuth
# --------------------------------------------------------------------------------------------------------------
def structure_preserving_integrators() -> tuple[str, ...]:
    """The built-in fixed-step integrators that declare a volume-preserving one-step map (``volume_preserving``
    in ``Integrator.describe``, implied by ``symplectic``), by name."""
    return tuple(name for name in built_in_names()
                 if not REGISTRY[name].adaptive and REGISTRY[name].describe()["volume_preserving"])


@dataclass(frozen=True)
class ReleaseAzimuthConfig:
    """The 3 m pendulum (spherical model, θ₀ = 0.05) released at each azimuth of ``azimuths_deg`` (from South
    towards East) at each latitude of ``latitudes_deg``, for ``duration_s``, sampled every ``output_interval_s``;
    every integrator of ``integrators`` (default: ``structure_preserving_integrators()``) at k·h = ``kh`` (the
    fixed-step loop shortens the step so that whole steps fill each output interval: 0.1 runs as 0.0904),
    against heyoka at tolerance ``reference_tol``."""

    model: str = "spherical"
    length_m: float = 3.0
    amplitude_m: float = 0.15
    latitudes_deg: tuple[float, ...] = (40.44, -0.18)
    azimuths_deg: tuple[float, ...] = tuple(float(a) for a in range(0, 181, 15))
    duration_s: float = 600.0
    output_interval_s: float = 0.45
    kh: float = 0.1
    integrators: tuple[str, ...] = field(default_factory=structure_preserving_integrators)
    reference_integrator: str = "heyoka_taylor"
    reference_tol: float = 1e-15


def grid_precession_rate(model: Model, params: PendulumParameters, solution: Solution) -> float:
    """The swing-plane rate (rad/s) measured from ``solution``'s output grid by the suite's one procedure
    (``bench.problems.turning_points``); NaN unless the run is ok."""
    if solution.status != STATUS_OK:
        return math.nan
    points = turning_points_from_grid(solution.t, solution.y, grid_accelerations(model, params, solution.y),
                                      released_from_rest(params))
    return precession_rate(points)[0]


def precession_vs_release_azimuth(config: ReleaseAzimuthConfig = ReleaseAzimuthConfig(),
                                  progress: bool = True) -> pd.DataFrame:
    """Precession-rate error of each integrator against the release azimuth: the swing's direction relative
    to the horizontal part of ω matters to integrators whose error is not isotropic (Verlet on the sphere: about
    0.09·θ₀ cos φ·Ω_E·(kh)² for a North-South release, ~100× less for an East one).

    Columns: latitude_deg, release_azimuth_deg, integrator, family, kh (the k·h the run took), kh_requested
    (``config.kh``), rate_rad_s, reference_rate_rad_s, error_earth (|rate − reference rate|/Ω_E, comparable
    across latitudes), status, message, plus the config's other scalars.
    """
    model = get_model(config.model)
    t_out = config.output_interval_s * np.arange(round(config.duration_s / config.output_interval_s) + 1)
    cases = [(lat, az) for lat in config.latitudes_deg for az in config.azimuths_deg]
    rows = []
    for latitude, azimuth in _progress(cases, "precession vs release azimuth", progress):
        params = PendulumParameters(length_m=config.length_m, latitude_deg=latitude, amplitude_m=config.amplitude_m,
                                    release_azimuth_deg=azimuth)
        problem = Problem(model=model, params=params, t_out=t_out)
        reference = solve_with_setting(config.reference_integrator, problem, config.reference_tol)
        reference_rate = grid_precession_rate(model, params, reference)
        for name in config.integrators:
            solution = solve_with_setting(name, problem, config.kh)
            rate = grid_precession_rate(model, params, solution)
            rows.append({
                "latitude_deg": latitude,
                "release_azimuth_deg": azimuth,
                "integrator": name,
                "family": family_of(name),
                "kh": (math.nan if solution.step_size_s is None
                       else solution.step_size_s * params.pendulum_frequency_rad_s),
                "kh_requested": config.kh,
                "rate_rad_s": rate,
                "reference_rate_rad_s": reference_rate,
                "error_earth": abs(rate - reference_rate) / params.earth_rate_rad_s,
                "status": solution.status,
                "message": solution.message,
            })
    return _with_config_columns(pd.DataFrame(rows), config,
                                exclude=("latitudes_deg", "azimuths_deg", "integrators", "kh"))


MIDPOINT_INTEGRATOR = "implicit_midpoint"
"""The integrator whose precession error ``midpoint_precession_law`` predicts."""


def midpoint_precession_law(azimuth: pd.DataFrame) -> pd.DataFrame:
    """The implicit midpoint rule's precession error in a ``precession_vs_release_azimuth`` table beside its law.

    The midpoint rule's one-step map on a linear system is the Cayley transform R(z) = (1 + z/2)/(1 − z/2): a
    mode of frequency ω turns by f(ω)h = 2 arctan(ωh/2) per step. The swing plane turns at the mean of the two
    circular modes' frequencies −a ± √(k² + a²) (a the local vertical rate), which the scheme maps to
    ≈ −a f′(k) = −a/(1 + (kh)²/4): slow by (kh)²/4 of the local rate to leading order, whatever the direction
    of release (integrators/README.md "Why not plain velocity Verlet"). Per latitude (rows with status ok): kh (the step taken), law_error_earth = (kh)²/4 ·
    |reference rate|/Ω_E (median over the azimuths), measured_error_earth (median of error_earth over the
    azimuths) and azimuth_variation (max/min − 1 of error_earth over the azimuths). Empty without that
    integrator's rows."""
    rows = []
    runs = azimuth[(azimuth["integrator"] == MIDPOINT_INTEGRATOR) & (azimuth["status"] == STATUS_OK)]
    for latitude, sweep in runs.groupby("latitude_deg", sort=False):
        kh = float(sweep["kh"].median())
        local_rate_earth = float((sweep["reference_rate_rad_s"].abs() / SIDEREAL_EARTH_RATE_RAD_S).median())
        errors = sweep["error_earth"].to_numpy(dtype=float)
        rows.append({
            "latitude_deg": float(latitude), "kh": kh,
            "law_error_earth": kh * kh / 4.0 * local_rate_earth,
            "measured_error_earth": float(np.median(errors)),
            "azimuth_variation": float(errors.max() / errors.min() - 1.0),
        })
    return pd.DataFrame(rows, columns=["latitude_deg", "kh", "law_error_earth", "measured_error_earth",
                                       "azimuth_variation"])


# --------------------------------------------------------------------------------------------------------------
# the seed note revisited
# --------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SeedConfig:
    """Assumptions for the seed note's figures, which give no numbers beyond ω = 2π/24 h and "2 minutes".

    Assumed (stated in the report): L = 10 m, y₀ = 0.5 m, latitude 45° (the seed's colatitude λ = 45°),
    released from rest at y = y₀ (seed §3), explicit Euler with h = 1 ms on the seed's eqs. (4)-(5), a
    reference of RK4 at h/4 on the same equations.
    """

    length_m: float = 10.0
    latitude_deg: float = 45.0
    amplitude_m: float = 0.5
    duration_s: float = 120.0
    output_spacing_s: float = 0.05
    euler_step_s: float = 1e-3
    reference_step_s: float = 2.5e-4


@dataclass
class SeedStudy:
    """The seed study's series (time on a common grid) and the scalar findings quoted in the report.

    ``series`` columns: t_s; seed_x_m, seed_y_m (eqs. 14-15, ω = 2π/24 h); exact_x_m, exact_y_m (exact linear
    solution, sidereal Ω_E); euler_x_m, euler_y_m, verlet_x_m, verlet_y_m (explicit Euler and Verlet on eqs. 4-5);
    euler_amplitude_theory_m A·√((1 + (kh)²)ⁿ) (the amplitude the energy growth implies); euler_energy_rel_error,
    euler_energy_theory (1 + (kh)²)ⁿ − 1, symplectic_energy_rel_error, verlet_energy_rel_error,
    model_energy_rel_error (the reference run of eqs. 4-5: the model's own energy change), model_energy_formula (∫
    dE/dt of the model, models/README.md "The seed's planar model"); seed_difference_m |r_Euler − r_eqs.14-15|;
    euler_error_m |r_Euler − r_ref|; model_difference_m |r_ref(eqs. 4-5) − r_exact(eqs. 6-7)|; approximation_gap_m
    |r_eqs.14-15 − r_exact|; approximation_gap_bound_m A·seed_gap_bound; day_length_difference_m
    |r_exact(sidereal) − r_exact(24 h)|; verlet_linear_error_m |r_Verlet(eqs. 6-7) − r_exact|. ``numbers``: scalar
    findings (SI units or dimensionless, named with their unit).
    """

    config: SeedConfig
    series: pd.DataFrame
    numbers: dict[str, float] = field(default_factory=dict)


def _params(config: SeedConfig, earth_rate_rad_s: float) -> PendulumParameters:
    return PendulumParameters(length_m=config.length_m, latitude_deg=config.latitude_deg,
                              amplitude_m=config.amplitude_m, earth_rate_rad_s=earth_rate_rad_s)


def _checked(solution: Solution, what: str) -> np.ndarray:
    if solution.status != STATUS_OK:
        raise RuntimeError(f"seed study: {what} ended with status {solution.status}: {solution.message}")
    return solution.y


def _distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(a[:, 0] - b[:, 0], a[:, 1] - b[:, 1])


def centrifugal_check(config: SeedConfig, position_m: tuple[float, float] = (0.3, 0.4)) -> dict[str, float]:
    """−ω×(ω×r) (per unit mass, m/s²) at r = (x, y, 0) in the seed's frame with ω = Ω(−sin λ, 0, cos λ)
    (λ the colatitude), computed with numpy's cross product, next to the seed's printed expansion
    (xω², −yω², 0) (seed §2). Source: the vector identity ω×(ω×r) = ω(ω·r) − r|ω|²."""
    colatitude = math.radians(90.0 - config.latitude_deg)
    omega = SEED_EARTH_RATE_RAD_S * np.array([-math.sin(colatitude), 0.0, math.cos(colatitude)])
    r = np.array([position_m[0], position_m[1], 0.0])
    correct = -np.cross(omega, np.cross(omega, r))
    w2 = SEED_EARTH_RATE_RAD_S ** 2
    return {
        "centrifugal_x_m": position_m[0], "centrifugal_y_m": position_m[1],
        "centrifugal_correct_x_m_s2": correct[0], "centrifugal_correct_y_m_s2": correct[1],
        "centrifugal_correct_z_m_s2": correct[2],
        "centrifugal_seed_x_m_s2": position_m[0] * w2, "centrifugal_seed_y_m_s2": -position_m[1] * w2,
        "centrifugal_over_gravity": float(np.linalg.norm(correct)) / STANDARD_GRAVITY_M_S2,
    }


def seed_revisited(config: SeedConfig = SeedConfig()) -> SeedStudy:
    """Reproduce the seed note's four figures and the numbers that correct them (see ``SeedStudy``)."""
    linear = get_model("linear")
    seed_planar = get_model("seed_planar")
    seed_params = _params(config, SEED_EARTH_RATE_RAD_S)
    sidereal_params = _params(config, SIDEREAL_EARTH_RATE_RAD_S)
    t = np.linspace(0.0, config.duration_s, int(round(config.duration_s / config.output_spacing_s)) + 1)
    seed_problem = Problem(model=seed_planar, params=seed_params, t_out=t)

    approx = seed_approximate(seed_params, t)
    exact_seed_rate = linear_exact(seed_params, t)
    exact = linear_exact(sidereal_params, t)
    euler = _checked(get_integrator("explicit_euler").solve(seed_problem, step_s=config.euler_step_s), "Euler")
    symplectic = _checked(get_integrator("symplectic_euler").solve(seed_problem, step_s=config.euler_step_s),
                          "symplectic Euler")
    verlet = _checked(get_integrator("verlet").solve(seed_problem, step_s=config.euler_step_s), "Verlet")
    reference = _checked(get_integrator("rk4").solve(seed_problem, step_s=config.reference_step_s), "reference")
    verlet_linear = _checked(get_integrator("verlet").solve(
        Problem(model=linear, params=sidereal_params, t_out=t), step_s=config.euler_step_s), "Verlet (linear)")

    kh = seed_params.pendulum_frequency_rad_s * config.euler_step_s
    # ∫ dE/dt dt along the reference, dE/dt = (2Ω_E cos φ / L) ẏ (xẋ + yẏ) (models/README.md "The seed's planar model")
    coefficient = 2.0 * SEED_EARTH_RATE_RAD_S * math.cos(seed_params.latitude_rad) / config.length_m
    x, y, vx, vy = reference.T
    power = coefficient * vy * (x * vx + y * vy)
    formula = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    formula /= energy_scale(seed_planar, seed_params)[1]

    series = pd.DataFrame({
        "t_s": t,
        "seed_x_m": approx[:, 0], "seed_y_m": approx[:, 1],
        "exact_x_m": exact[:, 0], "exact_y_m": exact[:, 1],
        "euler_x_m": euler[:, 0], "euler_y_m": euler[:, 1],
        "verlet_x_m": verlet[:, 0], "verlet_y_m": verlet[:, 1],
        "euler_amplitude_theory_m": config.amplitude_m * np.sqrt((1.0 + kh * kh) ** (t / config.euler_step_s)),
        "euler_energy_rel_error": relative_energy_error(seed_planar, seed_params, euler),
        "euler_energy_theory": (1.0 + kh * kh) ** (t / config.euler_step_s) - 1.0,
        "symplectic_energy_rel_error": relative_energy_error(seed_planar, seed_params, symplectic),
        "verlet_energy_rel_error": relative_energy_error(seed_planar, seed_params, verlet),
        "model_energy_rel_error": relative_energy_error(seed_planar, seed_params, reference),
        "model_energy_formula": formula,
        "seed_difference_m": _distance(euler, approx),
        "euler_error_m": _distance(euler, reference),
        "model_difference_m": _distance(reference, exact_seed_rate),
        "approximation_gap_m": _distance(approx, exact_seed_rate),
        "approximation_gap_bound_m": config.amplitude_m * seed_gap_bound(seed_params, t),
        "day_length_difference_m": _distance(exact, exact_seed_rate),
        "verlet_linear_error_m": _distance(verlet_linear, exact),
    })
    last_swing = np.nonzero(t >= t[-1] - seed_params.small_swing_period_s)[0]
    euler_reach = last_swing[np.argmax(np.hypot(euler[last_swing, 0], euler[last_swing, 1]))]
    numbers = {
        "kh": kh,
        "euler_amplitude_end_m": float(np.hypot(euler[euler_reach, 0], euler[euler_reach, 1])),
        "euler_amplitude_theory_end_m": float(series["euler_amplitude_theory_m"].iloc[euler_reach]),
        "verlet_amplitude_end_m": float(np.max(np.hypot(verlet[last_swing, 0], verlet[last_swing, 1]))),
        "euler_steps": config.duration_s / config.euler_step_s,
        "solar_day_rate_rad_s": SEED_EARTH_RATE_RAD_S,
        "sidereal_rate_rad_s": SIDEREAL_EARTH_RATE_RAD_S,
        "day_rate_shortfall": 1.0 - SEED_EARTH_RATE_RAD_S / SIDEREAL_EARTH_RATE_RAD_S,
        "seed_max_sideways_m": float(np.max(np.abs(approx[:, 0]))),
        "exact_max_sideways_m": float(np.max(np.abs(exact[:, 0]))),
        "euler_energy_final": float(series["euler_energy_rel_error"].iloc[-1]),
        "euler_energy_theory_final": float(series["euler_energy_theory"].iloc[-1]),
        "symplectic_energy_max": float(series["symplectic_energy_rel_error"].abs().max()),
        "verlet_energy_max": float(series["verlet_energy_rel_error"].abs().max()),
        "model_energy_max": float(series["model_energy_rel_error"].abs().max()),
        "model_energy_formula_max": float(np.max(np.abs(formula))),
        "model_energy_formula_mismatch": float(np.max(np.abs(formula - series["model_energy_rel_error"]))),
        "seed_difference_max_m": float(series["seed_difference_m"].max()),
        "euler_error_max_m": float(series["euler_error_m"].max()),
        "model_difference_max_m": float(series["model_difference_m"].max()),
        "approximation_gap_max_m": float(series["approximation_gap_m"].max()),
        "approximation_gap_bound_max_m": float(series["approximation_gap_bound_m"].max()),
        "approximation_gap_bound_day_m": config.amplitude_m * float(np.max(seed_gap_bound(
            seed_params, 2.0 * math.pi / SIDEREAL_EARTH_RATE_RAD_S
            + np.linspace(0.0, seed_params.small_swing_period_s, 1001)))),
        "day_length_difference_max_m": float(series["day_length_difference_m"].max()),
        "verlet_linear_error_max_m": float(series["verlet_linear_error_m"].max()),
        **centrifugal_check(config),
    }
    return SeedStudy(config=config, series=series, numbers=numbers)


# --------------------------------------------------------------------------------------------------------------
# registry of the stored studies
# --------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Study:
    """A study stored as a table named ``name`` in the results database. ``version`` counts the changes to what
    its table holds (a stored table carries it in column ``study_version``; a table without it is version 1):
    a stored table of another version is recomputed, never shown as if it were the current study's."""

    name: str
    compute: Callable[..., pd.DataFrame]
    config: object
    version: int = 1


STUDY_VERSION_COLUMN = "study_version"

STUDIES: dict[str, Study] = {
    study.name: study
    for study in (
        # version 2: one representative per family from the declared facts, one tolerance for the adaptive ones
        Study("study_long_time_energy", long_time_energy, LongTimeEnergyConfig(), version=2),
        Study("study_stability", stability_sweep, StabilitySweepConfig()),
        Study("study_precession_latitude", precession_vs_latitude, PrecessionLatitudeConfig()),
        # version 2: kh is the step taken (kh_requested the configured one); no rk4
        Study("study_release_azimuth", precession_vs_release_azimuth, ReleaseAzimuthConfig(), version=2),
    )
}


def stored_version(table: pd.DataFrame) -> int:
    """The study version a stored table was computed by (1 when it does not say)."""
    if STUDY_VERSION_COLUMN not in table.columns or table.empty:
        return 1
    return int(table[STUDY_VERSION_COLUMN].iloc[0])


class TableStore(Protocol):
    """What ``ensure_studies`` needs of a store: ``bench.run.store.ResultsStore``'s named tables."""

    def read_table(self, name: str) -> pd.DataFrame:
        """The stored table ``name``; ``KeyError`` when there is none."""

    def write_table(self, name: str, frame: pd.DataFrame) -> None:
        """Store ``frame`` as table ``name``, replacing it."""


def ensure_studies(store: TableStore | None, recompute: bool = False, configs: dict[str, object] | None = None,
                   progress: bool = True, store_computed: bool = True) -> dict[str, pd.DataFrame]:
    """Every study's table: read from ``store`` (``read_table``) or, when missing, of another ``Study.version``
    or ``recompute``, computed with its config (``configs`` overrides the defaults by study name) and written
    back (``write_table``) unless ``store_computed`` is false (a read-only database). ``store`` may be None:
    everything is computed and nothing is written."""
    configs = configs or {}
    tables = {}
    for name, study in STUDIES.items():
        stored = None
        if store is not None and not recompute:
            try:
                stored = store.read_table(name)
            except KeyError:
                stored = None
        if stored is None or stored.empty or stored_version(stored) != study.version:
            stored = study.compute(configs.get(name, study.config), progress=progress)
            stored[STUDY_VERSION_COLUMN] = study.version
            if store is not None and store_computed:
                store.write_table(name, stored)
        tables[name] = stored
    return tables


def _with_config_columns(frame: pd.DataFrame, config: Any, exclude: tuple[str, ...]) -> pd.DataFrame:
    """Add the config's scalar fields as constant columns (``config_<field>``) so a stored table says how it
    was made."""
    for name, value in asdict(cast(Any, config)).items():  # config: one of this module's dataclasses
        if name not in exclude:
            frame[f"config_{name}"] = value
    return frame


__all__ = [
    "LongTimeEnergyConfig", "PrecessionLatitudeConfig", "ReleaseAzimuthConfig", "STUDIES", "SeedConfig", "SeedStudy",
    "StabilitySweepConfig", "Study", "energy_trends", "ensure_studies", "family_representatives", "long_time_energy",
    "midpoint_precession_law", "precession_vs_latitude", "precession_vs_release_azimuth", "relative_energy_error",
    "seed_revisited", "solve_with_setting", "stability_sweep", "structure_preserving_integrators",
]
