"""The stability study: long runs and the one-step map's growth against k·h for every fixed-step integrator, with
and without Earth's rotation: the measured stability limit beside the declared one, and the growth per step where
rotation destabilises a method (symplectic Euler) beside its theory."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import cast

import numpy as np
import pandas as pd

from foucault_bench.bench.verdicts.columns import energy_verdicts
from foucault_bench.bench.verdicts.stability import measured_stability_limit, spectral_growth, step_matrix
from foucault_bench.integrators import (
    FixedStepIntegrator,
    Problem,
)
from foucault_bench.integrators.registry import REGISTRY
from foucault_bench.models import PendulumParameters, get_model
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S
from foucault_bench.bench.studies.common import (
    progress_over, with_config_columns,
)


@dataclass(frozen=True)
class StabilitySweepConfig:
    """Each fixed-step integrator of ``integrators`` (``None``: every registered one) on the linear model at each
    k·h of ``kh``, without Earth's rotation (Ω_E = 0: the undamped oscillator that defines ``stability_limit_kh``)
    and with it (Ω_E sidereal at ``latitude_deg``).

    Two measurements per point: a long run of ``steps`` steps (its max energy error and whether it diverged),
    and the growth per step of the scheme's own one-step map (``bench.verdicts.stability``), from which the
    measured limit is bisected to ``limit_resolution_kh``.
    """

    model: str = "linear"
    length_m: float = 10.0
    latitude_deg: float = 48.846
    amplitude_m: float = 1.0
    steps: int = 20_000
    kh: tuple[float, ...] = (0.01, 0.02, 0.05, *np.round(np.linspace(0.1, 4.0, 40), 6), 4.5, 5.0, 5.5, 6.0, 6.5)
    limit_resolution_kh: float = 1e-4
    integrators: tuple[str, ...] | None = None

    def chosen_integrators(self) -> tuple[str, ...]:
        """``integrators``, or every registered fixed-step integrator, by name."""
        if self.integrators is not None:
            return self.integrators
        return tuple(sorted(name for name, integrator in REGISTRY.items() if not integrator.adaptive))


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
    cases = [(name, rotation) for name in config.chosen_integrators() for rotation in (False, True)]
    rows = []
    for name, rotation in progress_over(cases, "stability sweep", progress):
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
    return with_config_columns(pd.DataFrame(rows), config, exclude=("kh", "integrators"))


def stability_sweep_parts(config: StabilitySweepConfig) -> list[StabilitySweepConfig]:
    """One config per integrator of ``config.chosen_integrators()``: their tables, one after another, are
    ``config``'s (each integrator is its own rows, and ``integrators`` is not a column)."""
    return [replace(config, integrators=(name,)) for name in config.chosen_integrators()]
