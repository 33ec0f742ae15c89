"""The timing protocol (bench.run.timing): repeats, the two clocks, and what the runner times."""

from __future__ import annotations

import math
import statistics
import time

import numpy as np
import pytest

from foucault_bench.bench.run.timing import CI_MIN_REPEATS, Timing, TimingPolicy, median_ci95, median_ci95_rel, time_repeated

POLICY = TimingPolicy(min_repeats=3, max_repeats=3)


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


def _ci95_indices(count: int) -> tuple[int, int] | None:
    """0-based indices of the sorted samples bounding the order-statistic 95 % interval of the median, from
    scipy's binomial distribution: the narrowest symmetric pair [x_(k), x_(n+1-k)] whose coverage
    1 − 2·P(B ≤ k − 1), B ~ Binomial(n, ½), is at least 95 %."""
    from scipy.stats import binom

    best = None
    for k in range(1, count // 2 + 1):
        if 1.0 - 2.0 * binom.cdf(k - 1, count, 0.5) >= 0.95:
            best = (k - 1, count - k)
    return best


def _expected_repeats(policy: TimingPolicy, repeat_costs_s: list[float]) -> int:
    """The protocol's stopping rule read literally, with the interval from ``_ci95_indices``: stop after the
    first n repeats when n ≥ max_repeats, or when their total reached min_total_s and either the total reached
    max_total_s or (n ≥ min_repeats and the interval's half-width ≤ target_ci95_rel × median)."""
    for count in range(1, policy.max_repeats + 1):
        done = repeat_costs_s[:count]
        total_s = math.fsum(done)
        if count == policy.max_repeats:
            return count
        if total_s < policy.min_total_s:
            continue
        if total_s >= policy.max_total_s:
            return count
        indices = _ci95_indices(count)
        if count >= policy.min_repeats and indices is not None:
            ordered = sorted(done)
            if ordered[indices[1]] - ordered[indices[0]] <= 2 * policy.target_ci95_rel * statistics.median(done):
                return count
    raise AssertionError("not reached")


def test_the_median_interval_is_the_order_statistic_one_and_covers_95_percent() -> None:
    """For every sample size up to 60, the bounds are the order statistics scipy's binomial distribution picks,
    and none exists below 6 repeats; its half-width relative to the median is what the rows store."""
    rng = np.random.default_rng(1)
    for count in range(1, 61):
        samples = list(rng.lognormal(0.0, 0.1, count))
        indices = _ci95_indices(count)
        interval = median_ci95(samples)
        assert (interval is None) == (indices is None) == (count < CI_MIN_REPEATS), count
        if interval is not None:
            ordered = sorted(samples)
            assert interval == (ordered[indices[0]], ordered[indices[1]])
            assert median_ci95_rel(samples) == pytest.approx(
                (interval[1] - interval[0]) / (2 * float(np.median(samples))), rel=1e-12)


def test_the_interval_covers_the_median_in_95_percent_of_samples() -> None:
    """Coverage measured on 4000 samples of 9 repeats from a skewed distribution of known median (exp(0) = 1
    for the log-normal): at least 95 % minus 3 binomial standard deviations (0.95 − 3·√(0.95·0.05/4000))."""
    rng = np.random.default_rng(2)
    trials = 4000
    covered = 0
    for _ in range(trials):
        lower, upper = median_ci95(list(rng.lognormal(0.0, 0.2, 9)))
        covered += lower <= 1.0 <= upper
    assert covered / trials >= 0.95 - 3 * math.sqrt(0.95 * 0.05 / trials)


# Costs with a pattern of spreads (dyadic, exact in binary: no sum sits on a rounding boundary of a threshold).
_COST_SEQUENCES_S = ([1 / 64], [1 / 8], [3 / 4], [1 / 1024], [1 / 16, 1 / 256, 1 / 4, 1 / 32, 1 / 2] * 8,
                     [2.0, 1 / 128], [1 / 128, 1 / 128 + 1 / 4096, 1 / 128 - 1 / 4096] * 20,
                     [1 / 256 * (1 + (index % 7) / 16) for index in range(60)])
_POLICIES = [TimingPolicy(min_repeats=minimum, max_repeats=maximum, min_total_s=floor_s, max_total_s=cap_s,
                          target_ci95_rel=target)
             for minimum in (1, 3, 6) for maximum in (minimum, 10, 40) for floor_s in (0.0, 0.05)
             for cap_s in (0.05, 0.3, 100.0) for target in (0.03, 0.2)]


@pytest.mark.parametrize("costs_s", _COST_SEQUENCES_S, ids=lambda c: f"{c[0]:g}s-{len(c)}")
def test_every_policy_repeats_by_its_rules(costs_s: list[float]) -> None:
    """The stopping rule for every combination of floor, caps and target, on steady and on spread costs; the
    stored figures are those of the repeats (the warm-up, the first cost, is never among them)."""
    for policy in _POLICIES:
        _check_policy(policy, costs_s)


def _check_policy(policy: TimingPolicy, costs_s: list[float]) -> None:
    run = _FakeRun(costs_s)
    per_call = [costs_s[min(index, len(costs_s) - 1)] for index in range(policy.max_repeats + 1)]
    expected = _expected_repeats(policy, per_call[1:])
    first, last, timing = run.timed(policy)
    assert timing is not None and timing.repeats == expected
    assert run.calls == expected + 1 and first == 1 and last == expected + 1
    repeats_s = per_call[1:expected + 1]
    assert list(timing.cpu_repeats_s) == repeats_s
    assert timing.cpu_median_s == statistics.median(repeats_s)
    assert timing.cpu_spread_s == max(repeats_s) - min(repeats_s)
    indices = _ci95_indices(expected)
    if indices is None:
        assert timing.cpu_ci95_rel is None
    else:
        ordered = sorted(repeats_s)
        assert timing.cpu_ci95_rel == pytest.approx(
            (ordered[indices[1]] - ordered[indices[0]]) / (2 * statistics.median(repeats_s)), rel=1e-12)
    assert timing.median_s == pytest.approx(statistics.median(repeats_s) + run.wait_s, rel=1e-12)
    assert timing.spread_s == pytest.approx(max(repeats_s) - min(repeats_s), abs=1e-12)
    assert timing.compile_s == pytest.approx(max(0.0, per_call[0] - statistics.median(repeats_s)), abs=1e-12)


def test_the_default_protocol_spends_where_precision_needs_it() -> None:
    """The default policy (bench/README.md "How a run is measured"): a steady 10-ms run stops at the floor of 6
    repeats with its precision established; a 10-ms run whose repeats scatter by ± 20 % repeats on until the
    time cap (0.1 s: 10 repeats) and stores the precision it reached; a 0.2-s run and a 1.5-s run are repeated
    once (no 95 % interval from 1). The quick matrix stops at 0.05 s or 5 repeats."""
    from foucault_bench.bench.run.matrix import load_matrix

    default, quick = load_matrix("default").timing, load_matrix("quick").timing
    assert default == TimingPolicy()
    scatter = [0.01 * (1.0 + 0.2 * math.sin(index)) for index in range(60)]
    for policy, costs_s, repeats, established in (
            (default, [0.01], CI_MIN_REPEATS, True), (default, scatter, 10, True), (default, [0.2], 1, False),
            (default, [1.5], 1, False), (quick, [0.01], 5, False), (quick, [0.02], 3, False), (quick, [0.2], 1, False)):
        _, _, timing = _FakeRun(costs_s).timed(policy)
        assert timing is not None and timing.repeats == repeats, (policy, costs_s[0])
        assert (timing.cpu_ci95_rel is not None) == established
        if costs_s is scatter:
            assert timing.cpu_ci95_rel > default.target_ci95_rel


def test_the_median_interval_holds_for_thousands_of_repeats() -> None:
    """A fast run may repeat thousands of times (a matrix's max_repeats): 2.0**n overflows past n = 1023, so the
    order statistics come from the binomial distribution; they equal the exact sum of binomial terms (Python's
    integers divide exactly), computed here for n = 2000."""
    import math

    from foucault_bench.bench.run.timing import median_ci95

    n = 2000
    tail, k = 0, 0
    while 2 * 40 * (tail + math.comb(n, k)) <= 2 * (1 << n):  # P(B <= k) <= 0.025, in exact integers
        tail += math.comb(n, k)
        k += 1
    assert median_ci95([float(value) for value in range(n)]) == (float(k - 1), float(n - k))


def test_calibration_chunks_follow_the_first_repeat_and_stay_within_their_share() -> None:
    """``calibrate`` runs after the first repeat and after a later one only while the chunks so far cost less
    than ``calibration_share`` of the repeats; the chunks never count in the repeats, and the calls interleave
    (a chunk right after the repeat it calibrates)."""
    run = _FakeRun([0.5] + [0.01] * 60)
    events: list[str] = []

    def repeat() -> int:
        events.append("run")
        return run()

    def calibrate() -> float:
        events.append("chunk")
        return 0.0045  # CPU of one chunk, from its own clock (the run's clocks do not move)

    policy = TimingPolicy(min_repeats=20, max_repeats=20, max_total_s=10.0)
    _, _, timing = time_repeated(repeat, policy, wall_clock=lambda: run.wall_s, cpu_clock=lambda: run.cpu_s,
                                 calibrate=calibrate, calibration_share=0.1)
    assert timing is not None and timing.repeats == 20 and timing.cpu_repeats_s == pytest.approx((0.01,) * 20)
    expected, chunks_s = ["run"], 0.0  # the warm-up, then the rule read literally
    for count in range(1, 21):
        expected.append("run")
        if chunks_s == 0.0 or chunks_s < 0.1 * 0.01 * count:
            expected.append("chunk")
            chunks_s += 0.0045
    assert events == expected and timing.calibration_chunks_s == (0.0045,) * expected.count("chunk")
    assert 1 < len(timing.calibration_chunks_s) < 20  # interleaved, not one per repeat at this share


def test_a_short_warm_up_call_replaces_the_warm_up_run() -> None:
    """Rule 1b: with ``warm_up`` the protocol calls it once, untimed as a repeat, and its CPU time is the compile
    time; the first repeat's result is the run's, and every call of ``call`` is a timed repeat (a run over the
    time cap is integrated once, not twice). A rejected first repeat ends the timing without a second call."""
    run = _FakeRun([0.3, 0.2, 0.21])  # 0.3 s: the warm-up (compilation); then two repeats of a 0.2-s run
    warm_ups: list[float] = []

    def warm_up() -> None:
        warm_ups.append(run.cpu_s)
        run()

    first, last, timing = time_repeated(run, TimingPolicy(), wall_clock=lambda: run.wall_s,
                                        cpu_clock=lambda: run.cpu_s, warm_up=warm_up)
    assert warm_ups == [0.0] and timing is not None
    assert first == last == 2 and run.calls == 2  # the warm-up (call 1), then one repeat over the 0.1-s cap
    assert timing.repeats == 1 and timing.cpu_repeats_s == pytest.approx((0.2,))
    assert timing.compile_s == pytest.approx(0.3) and timing.cpu_ci95_rel is None

    steady = _FakeRun([0.05] + [0.01] * 20)
    first, last, timing = time_repeated(steady, TimingPolicy(), wall_clock=lambda: steady.wall_s,
                                        cpu_clock=lambda: steady.cpu_s, warm_up=steady)
    assert timing is not None and timing.repeats == CI_MIN_REPEATS and first == 2 and last == CI_MIN_REPEATS + 1
    assert timing.compile_s == pytest.approx(0.05) and timing.cpu_repeats_s == pytest.approx((0.01,) * CI_MIN_REPEATS)

    rejected = _FakeRun([0.01])
    first, last, timing = time_repeated(rejected, TimingPolicy(), accept=lambda result: result == 0,
                                        warm_up=rejected)
    assert timing is None and rejected.calls == 2 and first == last == 2
