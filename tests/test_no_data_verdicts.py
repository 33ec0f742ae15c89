"""A run that diverged at step 0 has no data: every verdict is NULL in its stored row, never the 0.0 that
comparing the initial state with itself gives."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
import pytest

from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.bench.run.matrix import RunSpec
from foucault_bench.bench.run.execute import execute_run
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.run.timing import TimingPolicy
from foucault_bench.bench.schema import VERDICT_COLUMNS
from foucault_bench.integrators import register, unregister
from foucault_bench.integrators.adaptive import AdaptiveIntegrator
from foucault_bench.integrators.base import STATUS_DIVERGED, Solution, StreamedMetrics

NAME = "test_diverges_at_step_0"


@pytest.fixture
def diverges_at_step_0():
    """An integrator whose first step leaves the state non-finite, as a fixed-step loop reports it: the initial
    state in row 0, NaN after it, no step taken, the streamed energy maximum still at its starting 0."""

    @register
    class DivergesAtStepZero(AdaptiveIntegrator):
        name: ClassVar[str] = NAME
        family: ClassVar[str] = "test"
        order: ClassVar[None] = None
        reference: ClassVar[str] = "tests/test_no_data_verdicts.py"
        streams_step_metrics: ClassVar[bool] = True

        def _solve(self, problem, *, step_s, tol, monitor):
            y = np.full((problem.t_out.size, 4), np.nan)
            y[0] = problem.initial_state
            solution = Solution(t=problem.t_out, y=y, status=STATUS_DIVERGED, message="diverged after 0 steps",
                                steps=0, nfev=0)
            if monitor:
                solution.streamed = StreamedMetrics(energy_max_rel_error=0.0, energy_drift_per_s=math.nan,
                                                    turning_points=np.empty((0, 3)))
            return solution

    yield NAME
    unregister(NAME)


def test_a_run_diverged_at_step_0_stores_null_verdicts(diverges_at_step_0, tmp_path) -> None:
    scene = SCENES["seed_2min"]  # planar and released from rest: the analytic gaps apply too
    spec = RunSpec(scene=scene, integrator=diverges_at_step_0, kh=None, tol=1e-6, plugins=(),
                   timing=TimingPolicy(min_repeats=1, min_total_s=0.0, max_repeats=1), code_version="test")
    row = execute_run(spec, "m")
    assert row["status"] == STATUS_DIVERGED, row["message"]
    with ResultsStore(tmp_path / "db.sqlite") as store:
        store.write_run(row)
        cursor = store.connection.execute(f"SELECT {', '.join(VERDICT_COLUMNS)} FROM runs")
        stored = dict(zip(VERDICT_COLUMNS, cursor.fetchone(), strict=True))
    assert stored == dict.fromkeys(VERDICT_COLUMNS), stored  # NULL, i.e. unknown, for every verdict
