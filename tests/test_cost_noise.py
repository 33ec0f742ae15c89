"""Tests of the measurement tools for the timing protocol and the cost-change rule (bench/perf/cost_noise.py,
bench/perf/protocol_replay.py, bench/perf/slowed_rk4.py).

Timed repeats are made-up numbers: nothing here measures time. Each figure the tools print is recomputed here
from the rows by the rule read literally.
"""

from __future__ import annotations

import json
import math

import pandas as pd
import pytest

from foucault_bench.bench.perf.cost_noise import MARKER, compare, paired_counts
from foucault_bench.bench.perf.protocol_replay import replay, replayed_count
from foucault_bench.bench.run.timing import TimingPolicy


def _row(integrator: str, repeats_s: list[float], calibration_s: float = 0.01, ci95_rel: float | None = None,
         steps_energy_error: float | None = None) -> dict:
    ordered = sorted(repeats_s)
    middle = len(ordered) // 2
    median_s = ordered[middle] if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2
    return dict(integrator=integrator, cpu_time_s=median_s, cpu_time_repeats_s=json.dumps(repeats_s),
                calibration_cpu_s=calibration_s, cpu_time_ci95_rel=ci95_rel, compile_time_s=0.5,
                energy_max_rel_error_steps=steps_energy_error)


def test_a_replayed_policy_stops_where_its_rule_would_have():
    """Cap 0.1 s: repeats of 30 ms stop at the fourth (0.12 s ≥ 0.1 s, 0.09 s < 0.1 s); identical 10-ms repeats
    stop at the floor of 6 (a zero-width interval); three stored repeats of 10 ms are fewer than the rule wants."""
    policy = TimingPolicy(max_total_s=0.1)
    assert replayed_count([0.03] * 10, policy) == 4
    assert replayed_count([0.01] * 10, policy) == 6
    assert replayed_count([0.01] * 3, policy) is None


def test_the_replay_sums_the_stored_and_the_replayed_cpu():
    """Three rows (a 30-ms rk4 run with its per-step energy error, a 20-ms rk4 run of a matrix with
    ``step_energy = false``, a 10-ms cvode run): the runs once count the first rk4 run's monitored call and nothing
    for the others (no monitored call; cvode's warm-up over the first output interval is its compile time), the
    repeats and the replayed prefixes sum as cut by hand."""
    frame = pd.DataFrame([_row("rk4", [0.03] * 10, ci95_rel=0.0, steps_energy_error=1e-9),
                          _row("rk4", [0.02] * 10, ci95_rel=0.0), _row("cvode_adams", [0.01] * 10, ci95_rel=0.0)])
    result = replay(frame, TimingPolicy(max_total_s=0.1))
    assert result["once_s"] == pytest.approx(0.03)
    assert result["repeats_s"] == pytest.approx(0.3 + 0.2 + 0.1)
    assert result["replayed_repeats_s"] == pytest.approx(4 * 0.03 + 5 * 0.02 + 6 * 0.01)
    assert result["compile_s"] == pytest.approx(1.5)
    assert (result["runs_of_10ms"], result["agree"], result["disagree"], result["beyond_stored"]) == (3, 3, 0, 0)


def test_the_noise_comparison_counts_flags_and_ratios_by_the_rule():
    """Same-code rows agree to 1 % (no flag); rk4's repeats 10 % slower with a 1 % scatter are flagged slower;
    the ratios are the medians' and the calibrated ones divide by each row's calibration."""
    steady = [0.02 * (1 + 0.01 * math.sin(index)) for index in range(8)]
    before = pd.DataFrame([_row("rk4", steady), _row("verlet", steady)], index=["a rk4", "a verlet"])
    after = pd.DataFrame([_row("rk4", [value * 1.1 for value in steady], calibration_s=0.011),
                          _row("verlet", [value * 1.001 for value in steady])], index=["a rk4", "a verlet"])
    slowed = compare(before, after, rk4=True)
    assert (slowed["runs"], slowed["flagged"], slowed["slower"]) == (1, 1, 1)
    assert slowed["ratios"] == pytest.approx([1.1]) and slowed["calibrated"] == pytest.approx([1.0])
    same = compare(before, after, rk4=False)
    assert (same["runs"], same["flagged"]) == (1, 0) and same["ratios"] == pytest.approx([1.001])


def test_the_slowed_plugin_marks_its_rows_and_computes_the_same_numbers():
    """The plug-in's rk4 returns bitwise the same states as the registered one and appends its marker (what the
    measurement checks in the stored rows); the registry is restored afterwards, and importing the measurement
    script alone leaves it alone."""
    from foucault_bench.bench.problems.scenes import SCENES
    from foucault_bench.integrators import REGISTRY

    original = REGISTRY["rk4"]
    assert type(original).__module__ == "foucault_bench.integrators.methods.rk4"  # cost_noise is imported above
    try:
        from foucault_bench.bench.perf import slowed_rk4

        problem = SCENES["seed_2min"].problem()
        step_s = 0.2 / SCENES["seed_2min"].params.pendulum_frequency_rad_s
        plain = original.solve(problem, step_s=step_s, monitor=False)
        slowed = slowed_rk4.SlowedRK4().solve(problem, step_s=step_s, monitor=False)
        assert slowed.y.tobytes() == plain.y.tobytes() and MARKER in slowed.message
    finally:
        REGISTRY["rk4"] = original


def test_the_paired_measurement_counts_same_code_pairs_and_slowed_rk4_by_the_paired_rule():
    """One session, made-up times: an rk4 run 10 % slower on the slowed side (2 detections: same1 and same2
    against it, and 1 same-code pair), a verlet run equal on all sides (3 same-code pairs), a dop853 run whose
    same2 side is 20 % dearer (flagged in the 2 of its 3 pairs that include same2) and a 5-ms run left out."""
    base = [0.02 * (1 + 0.1 * (index % 4)) for index in range(10)]
    times = {"0": dict(same1=base, same2=base, slowed=[value * 1.1 for value in base]),
             "12": dict(same1=base, same2=base, slowed=base),
             "28": dict(same1=base, same2=[value * 1.2 for value in base], slowed=base),
             "3": dict(same1=[0.005] * 10, same2=[0.005] * 10, slowed=[0.0055] * 10)}
    counts = paired_counts([dict(times=times)], {"0": "rk4", "3": "rk4", "12": "verlet", "28": "dop853"})
    assert (counts["rk4"], counts["found"]) == (2, 2)
    assert (counts["same"], counts["flagged"]) == (7, 2)
    assert counts["rk4_ratios"] == pytest.approx([1.1, 1.1])


def test_a_paired_measurement_with_too_few_pairs_is_refused_before_timing(capsys):
    from foucault_bench.bench.perf.cost_noise import main

    with pytest.raises(SystemExit) as raised:
        main(["--paired", "--cycles", "3", "--process-sets", "2"])
    error = capsys.readouterr().err.strip().splitlines()
    assert raised.value.code == 2 and "--cycles × --process-sets >= 8" in error[-1]
