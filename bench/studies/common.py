"""What the studies share: running a registered integrator at a setting, the energy error, labels, the choice of
integrators from the facts each declares (``family_representatives``, ``structure_preserving_integrators``),
and the config columns a stored study table carries."""

from __future__ import annotations

import math
from dataclasses import asdict
from typing import Any, cast

import numpy as np
import pandas as pd
from tqdm import tqdm

from foucault_bench.bench.problems.reference import REFERENCE_INTEGRATOR
from foucault_bench.bench.schema import setting_label
from foucault_bench.bench.verdicts.columns import energy_scale
from foucault_bench.integrators import (
    Problem,
    Solution,
    get_integrator,
)
from foucault_bench.integrators.base import COST_COMPILED
from foucault_bench.integrators.registry import REGISTRY, built_in_names
from foucault_bench.models import Model, PendulumParameters


def relative_energy_error(model: Model, params: PendulumParameters, states: np.ndarray) -> np.ndarray:
    """(E(t) − E₀) / E_swing on the rows of ``states`` (columns x, y, ẋ, ẏ), with E₀ and E_swing from
    ``bench.verdicts.columns.energy_scale`` (the normalisation of the results table) and E from the model's own energy
    source evaluated on the arrays (``Model.energy_on_rows``: the compiled code's values, bit for bit)."""
    energy0, swing = energy_scale(model, params)
    energy = model.energy_on_rows(states, params.parameter_vector())
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


def progress_over(items: list, description: str, show: bool):
    return tqdm(items, desc=description, unit="run", disable=not show, leave=False)



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



def structure_preserving_integrators() -> tuple[str, ...]:
    """The built-in fixed-step integrators that declare a volume-preserving one-step map (``volume_preserving``
    in ``Integrator.describe``, implied by ``symplectic``), by name."""
    return tuple(name for name in built_in_names()
                 if not REGISTRY[name].adaptive and REGISTRY[name].describe()["volume_preserving"])



def with_config_columns(frame: pd.DataFrame, config: Any, exclude: tuple[str, ...]) -> pd.DataFrame:
    """Add the config's scalar fields as constant columns (``config_<field>``) so a stored table says how it
    was made."""
    for name, value in asdict(cast(Any, config)).items():  # config: one of this module's dataclasses
        if name not in exclude:
            frame[f"config_{name}"] = value
    return frame
