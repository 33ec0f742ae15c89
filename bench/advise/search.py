"""The targeted search ``advise`` runs when no stored run meets the target.

Its runs are stored like any matrix run (``bench.run.runner.run_matrix``, a matrix named ``advise-<scene>``): for
each integrator of the default matrix, at most ``MAX_ROUNDS`` runs, all integrators of a round in parallel. A
fixed-step method of order p starts at ``START_KH`` (or k·Δ, the largest step the grid allows) and moves to
kh · (½ target / error)^(1/p), the step its leading error term C·khᵖ predicts for half the target (Hairer,
Nørsett & Wanner, *Solving ODEs I*, §II.3: the global error of an order-p method is O(hᵖ)); once a step meets
the target, the next round tries the geometric mean of it and the coarser step that missed (a bisection in
log kh) to find a cheaper one. An adaptive method starts at tol = target and moves to tol · ½ target / error
(the error of a tolerance-controlled run is roughly proportional to the tolerance; same book, §II.4), with the
same bisection once one meets it. A fixed-step setting whose step count would exceed ``MAX_STEPS`` is not run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import cast

import numpy as np
import pandas as pd

from foucault_bench.bench.advise.target import Target
from foucault_bench.bench.problems.scenes import Scene
from foucault_bench.bench.run.store import ResultsStore

MAX_ROUNDS = 4
"""Runs per integrator in a search, at most."""
START_KH = 0.25
"""First step of a fixed-step search (k·h), unless the scene's grid allows less."""
MAX_STEPS = 20_000_000
"""A fixed-step setting needing more steps than this is left out of a search (tens of seconds per run)."""
SAFETY = 0.5
"""A search aims at this fraction of the target, so that the next run meets it despite higher-order terms."""
TOL_RANGE = (1e-14, 1e-3)
"""Tolerances a search may ask for: double precision ends below 1e-14."""


@dataclass
class _Probe:
    """One integrator's search: the settings tried and what they gave."""

    integrator: str
    adaptive: bool
    order: int | None
    tried: dict[float, float] = field(default_factory=dict)  # setting → error (inf: not ok)
    done: bool = False

    def next_setting(self, target: float, largest_kh: float, steps_per_kh: float) -> float | None:
        """The next kh or tol to run (None: stop). ``steps_per_kh``: steps of the scene at kh = 1."""
        if self.done:
            return None
        if not self.tried:
            first = min(max(target, TOL_RANGE[0]), TOL_RANGE[1]) if self.adaptive else min(START_KH, largest_kh)
            return self._allowed(first, steps_per_kh)
        meeting = {s: e for s, e in self.tried.items() if e <= target}
        missing = {s: e for s, e in self.tried.items() if e > target}
        if meeting:  # bisect (in log) between the cheapest meeting setting and the next coarser miss
            best = max(meeting)
            coarser = [s for s in missing if s > best]
            if not coarser:  # nothing coarser tried: the coarser setting the error model predicts
                ratio = SAFETY * target / max(meeting[best], 1e-300)
                proposal = best * (ratio if self.adaptive else ratio ** (1.0 / (self.order or 1)))
                proposal = min(proposal, TOL_RANGE[1] if self.adaptive else largest_kh)
                return proposal if proposal > 1.5 * best and proposal not in self.tried else None
            middle = math.sqrt(best * min(coarser))
            if middle in self.tried or min(coarser) / best < 1.5:
                return None
            return self._allowed(middle, steps_per_kh)
        last = min(self.tried)  # the finest setting tried so far
        error = self.tried[last]
        if not math.isfinite(error):
            proposal = last / 4.0
        elif self.adaptive:
            proposal = last * SAFETY * target / error
        else:
            proposal = last * (SAFETY * target / error) ** (1.0 / (self.order or 1))
        proposal = min(proposal, last / 1.5)
        if self.adaptive:
            proposal = max(proposal, TOL_RANGE[0])
            if proposal >= last:
                return None
        return self._allowed(proposal, steps_per_kh)

    def _allowed(self, setting: float, steps_per_kh: float) -> float | None:
        if not self.adaptive and steps_per_kh / setting > MAX_STEPS:
            return None
        return setting


def search(store: ResultsStore, scene: Scene, target: Target, runs: pd.DataFrame, *, jobs: int = 1,
           integrators: tuple[str, ...] | None = None, progress: bool = False) -> tuple[list[str], int]:
    """Run the targeted search (module docstring) with ``integrators`` (default: those of the default matrix);
    return the matrix ids it stored and how many runs it made."""
    from foucault_bench.bench.run.matrix import Matrix, RunSpec, code_version, load_matrix
    from foucault_bench.bench.run.runner import make_executor, run_matrix
    from foucault_bench.bench.run.timing import TimingPolicy
    from foucault_bench.integrators import REGISTRY

    names = integrators or list(dict.fromkeys(spec.integrator for spec in load_matrix("default").runs))
    probes = [_Probe(name, bool(REGISTRY[name].adaptive), REGISTRY[name].order) for name in names if name in REGISTRY]
    for probe in probes:  # what the store already says about each integrator
        for row in runs[runs["integrator"] == probe.integrator].itertuples():
            setting = row.tol if probe.adaptive else row.kh
            if pd.notna(setting):
                value = abs(getattr(row, target.metric))
                probe.tried[float(setting)] = value if row.status == "ok" and np.isfinite(value) else math.inf
    k = scene.params.pendulum_frequency_rad_s
    largest_kh = k * scene.output_interval_s
    steps_per_kh = k * scene.duration_s
    matrix_ids, planned = [], 0
    timing, code = TimingPolicy(), code_version()
    for round_number in range(MAX_ROUNDS):
        specs = []
        for probe in probes:
            setting = probe.next_setting(target.value, largest_kh, steps_per_kh)
            if setting is None:
                probe.done = True
                continue
            specs.append(RunSpec(scene=scene, integrator=probe.integrator, kh=None if probe.adaptive else setting,
                                 tol=setting if probe.adaptive else None, plugins=(), timing=timing,
                                 code_version=code, step_energy=False))  # no target uses the per-step energy
        if not specs:
            break
        matrix = Matrix(name=f"advise-{scene.name}", description=f"advise search for {target.metric} <= "
                        f"{target.value:g}, round {round_number + 1}", source="foucault-bench advise",
                        scenes=(scene,), runs=tuple(specs), plugins=(), timing=timing, step_energy=False)
        matrix_id = run_matrix(matrix, store, executor=make_executor(jobs), progress=progress)
        matrix_ids.append(matrix_id)
        planned += len(specs)
        rows = store.frame(matrix_id)
        for spec, probe in ((spec, next(p for p in probes if p.integrator == spec.integrator)) for spec in specs):
            row = rows[(rows["integrator"] == spec.integrator)].iloc[-1]
            value = abs(float(row[target.metric])) if pd.notna(row[target.metric]) else math.inf
            setting = cast(float, spec.tol if probe.adaptive else spec.kh)
            probe.tried[setting] = value if row["status"] == "ok" else math.inf
    return matrix_ids, planned
