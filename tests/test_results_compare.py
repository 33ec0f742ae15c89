"""``results --compare``: cost ratios only where both costs are positive and finite, and the output says which
runs were left out of each ratio and why (a compile time of 0 has no ratio; a failed run has no cost)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.commands.results import cost_ratio_text
from foucault_bench.bench.run.matrix import parse_matrix
from foucault_bench.bench.run.compare import COST_COLUMNS, compare_runs
from foucault_bench.bench.run.store import ResultsStore
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


# --- scenes are matched by physics; values shown exactly; each unmatched run's side named --------------------


def _matrix_run(store, runs, change=None) -> str:
    """A matrix run of ``runs`` (index in MATRIX.runs, run) as ``fake_row`` makes them, ``change`` applied."""
    matrix_id, _ = store.start_matrix_run(MATRIX, jobs=1, scheduler=None, resume=False)
    for index, run in runs:
        row = fake_row(run, matrix_id, index)
        store.write_run(change(index, row) if change else row)
    store.finish_matrix_run(matrix_id)
    return matrix_id


def test_a_scene_with_other_physics_under_the_same_name_is_named_not_listed_run_by_run(tmp_path, capsys):
    import dataclasses

    from foucault_bench.bench.problems.scene_key import scene_key

    scene = MATRIX.runs[0].scene
    elsewhere = dataclasses.replace(scene, params=dataclasses.replace(scene.params, latitude_deg=-60.0))
    other_runs = [dataclasses.replace(run, scene=elsewhere) for run in MATRIX.runs]
    with ResultsStore(tmp_path / "db.sqlite") as store:
        id_a = _matrix_run(store, enumerate(MATRIX.runs))
        id_b = _matrix_run(store, enumerate(other_runs))
    assert cli_main(["results", "--db", str(tmp_path / "db.sqlite"), "--compare", id_a, id_b]) == 1
    out = capsys.readouterr().out
    assert (f"scene {scene.name} has other physics in A ({scene_key(scene)}) than in B ({scene_key(elsewhere)})"
            in out)
    assert f"0 runs in both, {len(MATRIX.runs)} only in A, {len(other_runs)} only in B" in out
    assert f"only in A: {len(MATRIX.runs)} run(s) of scene {scene.name}" in out
    assert f"only in B: {len(other_runs)} run(s) of scene {scene.name}" in out
    assert "only in A: seed_2min" not in out  # not one line per run


def test_mismatched_values_are_printed_exactly_and_unmatched_runs_name_their_side(tmp_path, capsys):
    """B's reference error of one run is one ulp above A's: the two printed values read back as the two stored
    doubles (so they visibly differ). A holds a run B lacks, and B one A lacks: each is listed with its side."""
    def one_ulp_up(index, row):
        if index == 1:
            row["reference_error"] = float(np.nextafter(row["reference_error"], 1.0))
        return row

    with ResultsStore(tmp_path / "db.sqlite") as store:
        indexed = list(enumerate(MATRIX.runs))
        id_a = _matrix_run(store, indexed[:-1])
        id_b = _matrix_run(store, indexed[1:], change=one_ulp_up)
        frame_a, frame_b = store.frame(id_a), store.frame(id_b)
    assert cli_main(["results", "--db", str(tmp_path / "db.sqlite"), "--compare", id_a, id_b]) == 1
    out = capsys.readouterr().out
    line = next(line for line in out.splitlines() if "reference_error" in line and "kh=" in line)
    shown_a, shown_b = (float(value) for value in line.split()[-2:])
    run = MATRIX.runs[1]
    stored_a = frame_a.loc[frame_a["run_key"] == run.run_key, "reference_error"].item()
    stored_b = frame_b.loc[frame_b["run_key"] == run.run_key, "reference_error"].item()
    assert (shown_a, shown_b) == (stored_a, stored_b) and shown_a != shown_b
    first, last = MATRIX.runs[0], MATRIX.runs[-1]
    assert f"only in A: {first.scene.name} {first.integrator} kh={first.kh!r}" in out
    assert f"only in B: {last.scene.name} {last.integrator} tol={last.tol!r}" in out


def test_a_column_a_matrix_left_out_is_compared_only_where_both_runs_hold_it(tmp_path):
    """``energy_max_rel_error_steps`` (left out by a matrix with ``step_energy = false``): A holds it in every run;
    B leaves it out of run 0, holds A's value in run 1 and one ulp more in run 2. ``results --compare`` and the
    revision comparison (``history``, ``check --baseline``) report run 2 only; a NULL where the other side holds
    a value in any other accuracy column is still a change."""
    from foucault_bench.bench.history.changes import accuracy_changes

    column = "energy_max_rel_error_steps"

    def holds_it(index, row):
        row[column] = 1e-6 * (index + 1)
        return row

    def left_out_or_changed(index, row):
        row = holds_it(index, row)
        if index == 0:
            row.update({column: None})
        elif index == 2:
            row[column] = float(np.nextafter(row[column], 1.0))
        return row

    with ResultsStore(tmp_path / "db.sqlite") as store:
        runs = list(enumerate(MATRIX.runs))[:3]
        frame_a = store.frame(_matrix_run(store, runs, change=holds_it)).set_index("run_key")
        frame_b = store.frame(_matrix_run(store, runs, change=left_out_or_changed)).set_index("run_key")
    mismatches, _, _ = compare_runs(frame_a.reset_index(), frame_b.reset_index())
    changed_runs = [run for run in mismatches.loc[mismatches["column"] == column, "run"]]
    assert len(changed_runs) == 1 and f"kh={MATRIX.runs[2].kh!r}" in changed_runs[0], mismatches
    changes = [accuracy_changes(frame_a.loc[run.run_key].to_dict(), frame_b.loc[run.run_key].to_dict())
               for _, run in runs]
    assert changes == [[], [], [column]]
    before = frame_a.loc[MATRIX.runs[0].run_key].to_dict()
    assert accuracy_changes(before, {**before, "energy_max_rel_error": None}) == ["energy_max_rel_error"]
