"""``results --compare``: cost ratios only where both costs are positive and finite, and the output says which
runs were left out of each ratio and why (a compile time of 0 has no ratio; a failed run has no cost)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.commands.results import cost_ratio_text
from foucault_bench.bench.run.matrix import parse_matrix
from foucault_bench.bench.run.store import COST_COLUMNS, ResultsStore, compare_runs
from test_store import fake_row

MATRIX = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4", "cvode_bdf"], "kh": [0.2, 0.1, 0.05],
                       "tol": [1e-6, 1e-8]}, source="test", default_name="compare_test")


@pytest.fixture
def two_runs(tmp_path):
    """Matrix run A and a copy B with doubled wall times; compile times 0 (cached) in A's first run and in B's
    second, and no cost in B's third (a failed run)."""
    with ResultsStore(tmp_path / "db.sqlite") as store:
        ids = []
        for which in "AB":
            matrix_id, _ = store.start_matrix_run(MATRIX, jobs=1, scheduler=None, resume=False)
            for index, run in enumerate(MATRIX.runs):
                row = fake_row(run, matrix_id, index)
                if which == "B":
                    row["wall_time_s"] *= 2.0
                    row["compile_time_s"] = 0.0 if index == 1 else 0.75
                    if index == 2:
                        row.update(wall_time_s=None, compile_time_s=None, peak_rss_mb=None)
                elif index == 0:
                    row["compile_time_s"] = 0.0
                store.write_run(row)
            store.finish_matrix_run(matrix_id)
            ids.append(matrix_id)
        yield store, *ids


def test_ratios_only_where_both_costs_are_positive_and_finite(two_runs):
    store, id_a, id_b = two_runs
    _, costs, _ = compare_runs(store.frame(id_a), store.frame(id_b))
    ratios = costs["compile_time_s_ratio_b_over_a"].to_numpy()
    assert math.isnan(ratios[0]) and math.isnan(ratios[1]) and math.isnan(ratios[2])  # 0 in A, 0 in B, missing
    assert len(ratios) == 5 and np.all(ratios[3:] == 1.5)
    wall = costs["wall_time_s_ratio_b_over_a"].to_numpy()
    assert math.isnan(wall[2]) and np.allclose(np.delete(wall, 2), 2.0)


def test_compare_output_has_no_zero_inf_or_nan_ratio_and_says_what_was_left_out(two_runs, capsys):
    store, id_a, id_b = two_runs
    assert cli_main(["results", "--db", str(store.path), "--compare", id_a, id_b]) == 0
    out = capsys.readouterr().out
    table = [line.split() for line in out.splitlines() if line.split()[:1] in (["rk4"], ["cvode_bdf"])]
    assert len(table) == 2 and all(len(cells) == 1 + len(COST_COLUMNS) for cells in table)  # integrator, costs
    for cells in table:
        assert all(cell == "–" or 0.0 < float(cell) < math.inf for cell in cells[1:]), cells
    shared = len(MATRIX.runs)
    assert (f"compile_time_s: 3 of {shared} shared runs left out, 2 with a cost of 0 or below in A or B (nothing "
            "compiled, or a cached compile); 1 with no finite cost in A or B") in " ".join(out.split())
    assert f"wall_time_s: 1 of {shared} shared runs left out, 1 with no finite cost" in " ".join(out.split())
    assert "identical bit for bit" in out


def test_an_integrator_with_no_comparable_run_shows_a_dash(two_runs):
    store, id_a, id_b = two_runs
    _, costs, _ = compare_runs(store.frame(id_a), store.frame(id_b))
    costs.loc[costs["integrator"] == "cvode_bdf", "compile_time_s_ratio_b_over_a"] = np.nan
    row = next(line for line in cost_ratio_text(costs).splitlines() if line.startswith("cvode_bdf"))
    assert "–" in row
