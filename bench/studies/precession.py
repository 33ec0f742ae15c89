"""The precession studies.

* ``precession_vs_latitude``: the swing plane's measured rate for many latitudes at once (one heyoka
  ``taylor_adaptive_batch``, one batch element per latitude), against −Ω_E sin φ and its Airy correction.
* ``precession_vs_release_azimuth``: the precession error of each fixed-step integrator declaring a
  volume-preserving one-step map (``structure_preserving_integrators``) against the direction of release, at a
  mid-latitude and near the equator (an East release hides what a North-South one shows), at the step each
  run took; ``midpoint_precession_law`` sets the implicit midpoint rule's error beside its (kh)²/4 law.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from foucault_bench.bench.verdicts.columns import released_from_rest
from foucault_bench.bench.problems.turning_points import grid_accelerations, precession_rate, turning_points_from_grid
from foucault_bench.integrators import (
    STATUS_OK,
    Problem,
    Solution,
)
from foucault_bench.models import Model, PendulumParameters, get_model
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S
from foucault_bench.bench.studies.common import (
    family_of, progress_over, solve_with_setting,
    structure_preserving_integrators, with_config_columns,
)


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
    for t_chunk in progress_over(list(chunks), "precession vs latitude", progress):
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
    return with_config_columns(pd.DataFrame(rows), config, exclude=())



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
    for latitude, azimuth in progress_over(cases, "precession vs release azimuth", progress):
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
    return with_config_columns(pd.DataFrame(rows), config,
                                exclude=("latitudes_deg", "azimuths_deg", "integrators", "kh"))


def release_azimuth_parts(config: ReleaseAzimuthConfig) -> list[ReleaseAzimuthConfig]:
    """One config per latitude of ``config.latitudes_deg``: their tables, one after another, are ``config``'s (the
    rows go latitude by latitude, and ``latitudes_deg`` is not a column)."""
    return [replace(config, latitudes_deg=(latitude,)) for latitude in config.latitudes_deg]


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
