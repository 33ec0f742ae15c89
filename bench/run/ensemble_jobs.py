"""The members of one ensemble configuration run through one function: the seam where a batch path goes.

An ensemble's members (``bench.problems.ensemble``) that share an integrator and a setting are one configuration
(``configurations``: keyed by ensemble, integrator and the setting asked for). ``run_members`` runs them and
returns their rows in order; today it runs each member by itself through the runner (``bench.run.execute.
execute_run``: its own reference, timing and verdicts), so that its rows are exactly the rows of one-by-one
runs. A batch implementation (heyoka's batch mode for the references and Taylor runs, one compiled loop over
the members for the fixed-step methods) replaces its body and keeps its contract: one row per member, in the
members' order, each a row ``execute_run`` could have made.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Iterable

if TYPE_CHECKING:
    from foucault_bench.bench.run.matrix import RunSpec

ConfigurationKey = tuple[str, str, str]
"""(ensemble, integrator, setting asked for)."""


def configurations(specs: Iterable[RunSpec]) -> dict[ConfigurationKey, list[RunSpec]]:
    """The ensemble members among ``specs`` by configuration, each list in the given order; runs of scenes of
    their own are left out."""
    groups: dict[ConfigurationKey, list[RunSpec]] = {}
    for spec in specs:
        if spec.scene.ensemble:
            groups.setdefault((spec.scene.ensemble, spec.integrator, spec.setting), []).append(spec)
    return groups


def run_members(specs: list[RunSpec], matrix_id: str) -> list[dict[str, Any]]:
    """The rows of one configuration's members (``configurations``), in order (module docstring)."""
    from foucault_bench.bench.run.execute import execute_run

    keys = {(spec.scene.ensemble, spec.integrator, spec.setting) for spec in specs}
    if len(keys) > 1:
        raise ValueError(f"run_members takes the members of one configuration, got {len(keys)}")
    return [execute_run(spec, matrix_id) for spec in specs]
