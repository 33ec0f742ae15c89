"""The timing protocol (bench.run.timing): repeats, the two clocks, and what the runner times."""

from __future__ import annotations

import math
import statistics
import time

import numpy as np
import pytest

from foucault_bench.bench.run.timing import Timing, TimingPolicy, time_repeated

POLICY = TimingPolicy(min_repeats=3, min_total_s=0.0, max_repeats=3)


def test_cpu_time_leaves_out_waiting_and_wall_time_does_not() -> None:
    def waits() -> int:
        time.sleep(0.02)  # the thread waits: wall time passes, the thread's CPU time does not
        return 1

    first, last, timing = time_repeated(waits, POLICY)
    assert timing is not None and first == last == 1 and timing.repeats == 3
    assert timing.median_s >= 0.02
    assert timing.cpu_median_s < 0.25 * timing.median_s
    assert 0.0 <= timing.cpu_spread_s and 0.0 <= timing.spread_s


def test_cpu_time_counts_computing() -> None:
    data = np.random.default_rng(0).random(200_000)

    def computes() -> float:
        return float(np.sort(data)[0])

    _, _, timing = time_repeated(computes, POLICY)
    assert timing is not None and timing.cpu_median_s > 0.0
    # a computing thread's CPU time cannot exceed the wall time it took (one thread; clock granularity aside)
    assert timing.cpu_median_s <= timing.median_s * 1.05 + 1e-3


def test_rejected_warm_up_is_not_timed() -> None:
    calls: list[int] = []

    def fails() -> str:
        calls.append(1)
        return "failed"

    first, last, timing = time_repeated(fails, POLICY, accept=lambda r: r == "ok")
    assert timing is None and len(calls) == 1 and first == last == "failed"


def test_every_built_in_integrator_says_how_its_cost_arises() -> None:
    """A plug-in may leave ``cost_basis`` undeclared (``None``); the report then says so."""
    from foucault_bench.integrators import REGISTRY, built_in_names
    from foucault_bench.integrators.base import COST_BASES

    undeclared = {name: REGISTRY[name].cost_basis for name in built_in_names()
                  if REGISTRY[name].cost_basis not in COST_BASES}
    assert not undeclared, undeclared


class _FakeRun:
    """A call whose CPU cost per call is taken from ``cpu_costs_s`` in turn (the warm-up first) and whose wall
    time is that cost plus ``wait_s`` (time spent waiting for a core); its two clocks advance only when it
    runs, so the protocol's decisions are exact and no real time is measured."""

    def __init__(self, cpu_costs_s: list[float], wait_s: float = 0.25) -> None:
        self.cpu_costs_s = cpu_costs_s
        self.wait_s = wait_s
        self.calls = 0
        self.cpu_s = 0.0
        self.wall_s = 0.0

    def __call__(self) -> int:
        cost_s = self.cpu_costs_s[min(self.calls, len(self.cpu_costs_s) - 1)]
        self.cpu_s += cost_s
        self.wall_s += cost_s + self.wait_s
        self.calls += 1
        return self.calls

    def timed(self, policy: TimingPolicy) -> tuple[int, int, Timing | None]:
        return time_repeated(self, policy, wall_clock=lambda: self.wall_s, cpu_clock=lambda: self.cpu_s)


def _expected_repeats(policy: TimingPolicy, warm_up_cpu_s: float, repeat_costs_s: list[float]) -> int:
    """The protocol's rules read literally: a single repeat after a warm-up over ``single_repeat_over_s``;
    else the fewest repeats n with n ≥ min_repeats and the first n repeats' CPU time ≥ min_total_s, but
    never more than max_repeats."""
    if warm_up_cpu_s > policy.single_repeat_over_s:
        return 1
    for count in range(policy.min_repeats, policy.max_repeats + 1):
        if math.fsum(repeat_costs_s[:count]) >= policy.min_total_s:
            return count
    return policy.max_repeats


# Dyadic costs (exact in binary), so that no sum sits on a rounding boundary of a threshold.
_COST_SEQUENCES_S = ([1 / 64], [1 / 8], [3 / 4], [1 / 1024], [1 / 16, 1 / 256, 1 / 4, 1 / 32, 1 / 2] * 4,
                     [2.0, 1 / 128])
_POLICIES = [TimingPolicy(min_repeats=minimum, min_total_s=total, max_repeats=maximum, single_repeat_over_s=1.0)
             for minimum in (1, 2, 3) for maximum in (minimum, 5, 20) for total in (0.0, 0.05, 0.5, 100.0)]


@pytest.mark.parametrize("policy", _POLICIES, ids=lambda p: f"min{p.min_repeats}-max{p.max_repeats}-{p.min_total_s}s")
@pytest.mark.parametrize("costs_s", _COST_SEQUENCES_S, ids=lambda c: f"{c[0]:g}s")
def test_every_policy_repeats_by_its_rules(policy: TimingPolicy, costs_s: list[float]) -> None:
    """At least min_repeats, then until min_total_s of CPU time or max_repeats, for every combination (the
    quick matrix's min_repeats = 1 included); a single repeat after a warm-up over single_repeat_over_s."""
    run = _FakeRun(costs_s)
    per_call = [costs_s[min(index, len(costs_s) - 1)] for index in range(policy.max_repeats + 1)]
    expected = _expected_repeats(policy, per_call[0], per_call[1:])
    first, last, timing = run.timed(policy)
    assert timing is not None and timing.repeats == expected
    assert run.calls == expected + 1 and first == 1 and last == expected + 1
    repeats_s = per_call[1:expected + 1]
    assert timing.cpu_median_s == statistics.median(repeats_s)
    assert timing.cpu_spread_s == max(repeats_s) - min(repeats_s)
    assert timing.median_s == pytest.approx(statistics.median(repeats_s) + run.wait_s, rel=1e-12)
    assert timing.spread_s == pytest.approx(max(repeats_s) - min(repeats_s), abs=1e-12)
    assert timing.compile_s == pytest.approx(max(0.0, per_call[0] + run.wait_s - timing.median_s), abs=1e-12)


def test_the_quick_matrix_repeats_a_fast_run_and_measures_a_spread() -> None:
    """The quick matrix (min_repeats = 1, min_total_s = 0.05 s, max_repeats = 5; bench/README.md "How a run is
    measured"): a 10-ms run is repeated 5 times, a 20-ms one 3 times (60 ms ≥ 50 ms), a 0.2-s one once; the
    default policy (3 repeats and 0.5 s, at most 20) repeats a 10-ms run 20 times and a 0.2-s one 3 times,
    and a run whose warm-up took 1.5 s once."""
    from foucault_bench.bench.run.matrix import load_matrix

    quick = load_matrix("quick").timing
    default = load_matrix("default").timing
    assert default == TimingPolicy()
    for policy, cost_s, repeats in ((quick, 0.01, 5), (quick, 0.02, 3), (quick, 0.2, 1),
                                    (default, 0.01, 20), (default, 0.2, 3), (default, 1.5, 1)):
        run = _FakeRun([cost_s, *[cost_s * (1.0 + 0.01 * index) for index in range(1, 25)]])
        _, _, timing = run.timed(policy)
        assert timing is not None and timing.repeats == repeats, (policy, cost_s)
        assert (timing.cpu_spread_s > 0.0) == (repeats > 1)
