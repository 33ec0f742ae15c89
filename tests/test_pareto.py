"""Pareto fronts, best of family and matched accuracy (bench.verdicts.pareto) on synthetic results rows."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.schema import COLUMN_NAMES
from foucault_bench.bench.verdicts import pareto


def rows(records: list[tuple]) -> pd.DataFrame:
    """Results rows from (scene, integrator, family, kh, tol, status, reference_error, wall_time_s)."""
    frame = pd.DataFrame(records, columns=["scene", "integrator", "family", "kh", "tol", "status",
                                           "reference_error", "wall_time_s"])
    for column in COLUMN_NAMES:
        if column not in frame:
            frame[column] = np.nan
    frame["model"] = "linear"
    return frame


def random_rows(seed: int, n: int = 60) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    integrators = [("a", "f1"), ("b", "f1"), ("c", "f2"), ("d", "f3")]
    records = []
    for i in range(n):
        name, family = integrators[i % 4]
        status = rng.choice(["ok", "ok", "ok", "diverged", "failed"])
        records.append(("s" + str(i % 2), name, family, 2.0 ** -(i % 7), np.nan, status,
                        10 ** rng.uniform(-12, 0), 10 ** rng.uniform(-4, 0)))
    return rows(records)


@pytest.mark.parametrize("seed", range(5))
def test_front_is_exactly_the_undominated_ok_runs(seed: int) -> None:
    frame = random_rows(seed)
    front = pareto.pareto_front(frame)
    ok = frame[frame["status"] == "ok"]
    for scene, runs in ok.groupby("scene"):
        cost, error = runs["wall_time_s"].to_numpy(), runs["reference_error"].to_numpy()
        dominated = [((cost <= c) & (error <= e) & ((cost < c) | (error < e))).any()
                     for c, e in zip(cost, error, strict=True)]
        expected = set(zip(runs["integrator"][~np.array(dominated)], runs["kh"][~np.array(dominated)], strict=True))
        scene_front = front[front["scene"] == scene]
        assert set(zip(scene_front["integrator"], scene_front["kh"], strict=True)) == expected
        assert scene_front["wall_time_s"].is_monotonic_increasing
        assert scene_front["error"].is_monotonic_decreasing


def test_failed_and_diverged_runs_never_win_and_cpu_time_is_preferred() -> None:
    frame = rows([("s", "a", "f", 0.1, np.nan, "ok", 1e-4, 1.0),
                  ("s", "b", "g", 0.1, np.nan, "diverged", 1e-9, 0.001),
                  ("s", "c", "g", np.nan, 1e-6, "ok", 1e-7, 2.0)])
    assert list(pareto.pareto_front(frame)["integrator"]) == ["a", "c"]
    assert pareto.cost_column(frame) == "wall_time_s"
    frame["cpu_time_s"] = [3.0, 0.001, 0.5]  # c is now cheaper and more accurate than a
    assert pareto.cost_column(frame) == "cpu_time_s"
    assert list(pareto.pareto_front(frame)["integrator"]) == ["c"]


@pytest.mark.parametrize("seed", range(5))
def test_matched_accuracy_names_the_cheapest_run_meeting_each_target(seed: int) -> None:
    frame = random_rows(seed)
    table = pareto.matched_accuracy(frame, targets=(1e-2, 1e-5, 1e-13))
    for row in table.itertuples():
        ok = frame[(frame["scene"] == row.scene) & (frame["status"] == "ok")]
        met = ok[ok["reference_error"] <= row.target]
        if met.empty:
            assert row.outcome == "not reached"
            continue
        assert row.wall_time_s == met["wall_time_s"].min()
        others = met[met["integrator"] != row.integrator]
        if others.empty:
            assert pd.isna(row.runner_up)
        else:
            assert row.runner_up_wall_time_s == others["wall_time_s"].min()
            assert row.ratio == pytest.approx(row.runner_up_wall_time_s / row.wall_time_s)
            assert row.ratio >= 1.0


def test_best_of_family_and_metrics_that_do_not_apply() -> None:
    frame = rows([("s", "a", "f", 0.1, np.nan, "ok", 1e-4, 1.0),
                  ("s", "a", "f", 0.05, np.nan, "ok", 1e-6, 2.0),
                  ("s", "c", "g", np.nan, 1e-6, "ok", 1e-7, 0.5)])
    best = pareto.best_of_family(frame).set_index("family")
    assert best.loc["f", "setting"] == "kh=0.05" and best.loc["f", "front_points"] == 0
    assert best.loc["g", "front_points"] == 1
    frame["energy_max_rel_error"] = 1e-3
    assert "energy_max_rel_error" in pareto.metrics_present(frame)
    frame["model"] = "seed_planar"  # no energy integral: its energy error measures the model
    assert "energy_max_rel_error" not in pareto.metrics_present(frame)
