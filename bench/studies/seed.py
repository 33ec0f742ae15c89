"""The seed note revisited: the numbers behind the seed note's figures and their corrections, which
``reports.seed`` draws and writes. The integrators are the ones the note used (explicit Euler on its eqs. 4-5)
and the corrections its findings name (symplectic Euler, Verlet; RK4 at a quarter of the step as the reference)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np
import pandas as pd

from foucault_bench.bench.problems.scenes import SEED_EARTH_RATE_RAD_S
from foucault_bench.bench.verdicts.columns import energy_scale
from foucault_bench.integrators import (
    STATUS_OK,
    Problem,
    Solution,
    get_integrator,
)
from foucault_bench.models import PendulumParameters, get_model
from foucault_bench.models.analytic import linear_exact, seed_approximate, seed_gap_bound
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S, STANDARD_GRAVITY_M_S2
from foucault_bench.bench.studies.common import relative_energy_error, with_config_columns


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


_SERIES_COLUMNS = frozenset((
    "t_s", "seed_x_m", "seed_y_m", "exact_x_m", "exact_y_m", "euler_x_m", "euler_y_m", "verlet_x_m", "verlet_y_m",
    "euler_amplitude_theory_m", "euler_energy_rel_error", "euler_energy_theory", "symplectic_energy_rel_error",
    "verlet_energy_rel_error", "model_energy_rel_error", "model_energy_formula", "seed_difference_m",
    "euler_error_m", "model_difference_m", "approximation_gap_m", "approximation_gap_bound_m",
    "day_length_difference_m", "verlet_linear_error_m",
))
"""The columns of ``SeedStudy.series`` (``seed_series`` adds the config's)."""


def seed_series(config: SeedConfig = SeedConfig(), progress: bool = False) -> pd.DataFrame:
    """The seed study's table (stored as ``study_seed``, ``bench.studies.STUDIES``): the series of ``SeedStudy``
    on the output grid, plus the config's fields as constant ``config_<field>`` columns. ``progress`` is unused
    (the study is a handful of runs of a few hundred thousand steps)."""
    del progress
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
    return with_config_columns(series, config, exclude=())


def seed_study(table: pd.DataFrame) -> SeedStudy:
    """The ``SeedStudy`` of a ``seed_series`` table (stored or just computed): its config from the ``config_``
    columns, its series from the others, and the scalar findings computed from both."""
    config = SeedConfig(**{f.name: float(table[f"config_{f.name}"].iloc[0]) for f in fields(SeedConfig)})
    series = table[[name for name in table.columns if name in _SERIES_COLUMNS]].reset_index(drop=True)
    seed_params = _params(config, SEED_EARTH_RATE_RAD_S)
    t = series["t_s"].to_numpy()
    euler_x, euler_y = series["euler_x_m"].to_numpy(), series["euler_y_m"].to_numpy()
    verlet_x, verlet_y = series["verlet_x_m"].to_numpy(), series["verlet_y_m"].to_numpy()
    formula = series["model_energy_formula"].to_numpy()
    last_swing = np.nonzero(t >= t[-1] - seed_params.small_swing_period_s)[0]
    euler_reach = last_swing[np.argmax(np.hypot(euler_x[last_swing], euler_y[last_swing]))]
    numbers = {
        "kh": seed_params.pendulum_frequency_rad_s * config.euler_step_s,
        "euler_amplitude_end_m": float(np.hypot(euler_x[euler_reach], euler_y[euler_reach])),
        "euler_amplitude_theory_end_m": float(series["euler_amplitude_theory_m"].iloc[euler_reach]),
        "verlet_amplitude_end_m": float(np.max(np.hypot(verlet_x[last_swing], verlet_y[last_swing]))),
        "euler_steps": config.duration_s / config.euler_step_s,
        "solar_day_rate_rad_s": SEED_EARTH_RATE_RAD_S,
        "sidereal_rate_rad_s": SIDEREAL_EARTH_RATE_RAD_S,
        "day_rate_shortfall": 1.0 - SEED_EARTH_RATE_RAD_S / SIDEREAL_EARTH_RATE_RAD_S,
        "seed_max_sideways_m": float(np.max(np.abs(series["seed_x_m"].to_numpy()))),
        "exact_max_sideways_m": float(np.max(np.abs(series["exact_x_m"].to_numpy()))),
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


def seed_revisited(config: SeedConfig = SeedConfig()) -> SeedStudy:
    """Reproduce the seed note's four figures and the numbers that correct them (see ``SeedStudy``)."""
    return seed_study(seed_series(config))
