"""The timing protocol (bench.run.timing): repeats, the two clocks, and what the runner times."""

from __future__ import annotations

import time

import numpy as np

from foucault_bench.bench.run.timing import TimingPolicy, time_repeated

POLICY = TimingPolicy(min_repeats=3, min_total_s=0.0, max_repeats=3)


def test_cpu_time_leaves_out_waiting_and_wall_time_does_not() -> None:
    def waits() -> int:
        time.sleep(0.02)  # the thread waits: wall time passes, the thread's CPU time does not
        return 1

    first, last, timing = time_repeated(waits, POLICY)
    assert first == last == 1 and timing.repeats == 3
    assert timing.median_s >= 0.02
    assert timing.cpu_median_s < 0.25 * timing.median_s
    assert 0.0 <= timing.cpu_spread_s and 0.0 <= timing.spread_s


def test_cpu_time_counts_computing() -> None:
    data = np.random.default_rng(0).random(200_000)

    def computes() -> float:
        return float(np.sort(data)[0])

    _, _, timing = time_repeated(computes, POLICY)
    assert timing.cpu_median_s > 0.0
    # a computing thread's CPU time cannot exceed the wall time it took (one thread; clock granularity aside)
    assert timing.cpu_median_s <= timing.median_s * 1.05 + 1e-3


def test_rejected_warm_up_is_not_timed() -> None:
    calls = []
    first, last, timing = time_repeated(lambda: calls.append(1) or "failed", POLICY, accept=lambda r: r == "ok")
    assert timing is None and len(calls) == 1 and first == last == "failed"


def test_every_built_in_integrator_says_how_its_cost_arises() -> None:
    """A plug-in may leave ``cost_basis`` undeclared (``None``); the report then says so."""
    from foucault_bench.integrators import REGISTRY, built_in_names
    from foucault_bench.integrators.base import COST_BASES

    undeclared = {name: REGISTRY[name].cost_basis for name in built_in_names()
                  if REGISTRY[name].cost_basis not in COST_BASES}
    assert not undeclared, undeclared
