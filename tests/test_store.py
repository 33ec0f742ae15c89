"""The results store: rows round-trip exactly, resume bookkeeping, study tables, exports and comparisons."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.run.matrix import parse_matrix
from foucault_bench.bench.schema import COLUMN_NAMES, SCHEMA_VERSION
from foucault_bench.bench.run.compare import compare_runs
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.run.summary import summarize

MATRIX = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4", "cvode_bdf"], "kh": [0.2, 0.1],
                       "tol": [1e-6]}, source="test", default_name="store_test")


def fake_row(run, matrix_id: str, index: int) -> dict:
    """A complete row with distinct, awkward values (NaN, tiny and huge floats) for round-trip checks."""
    row = dict.fromkeys(COLUMN_NAMES)
    row.update(run_key=run.run_key, matrix_id=matrix_id, scene=run.scene.name, scene_key=scene_key(run.scene),
               model=run.scene.model,
               integrator=run.integrator, family="test", kh=run.kh, tol=run.tol, step_s=run.step_s, status="ok",
               message="", duration_s=run.scene.duration_s, n_out=61 + index, energy_conserved=1,
               energy_max_rel_error=np.float64(1.0 / 3.0 + index), energy_drift_per_s=-2.5e-300,
               reference_error=math.nan if index == 0 else 10.0 ** -(index + 3), precession_rate_rad_s=-5.48e-5,
               wall_time_s=0.01 * (index + 1), compile_time_s=0.5, peak_rss_mb=300.0, nfev=np.int64(1000 + index),
               steps=100 + index, repeats=3)
    return row


@pytest.fixture
def filled(tmp_path):
    with ResultsStore(tmp_path / "results" / "db.sqlite") as store:
        matrix_id, stored = store.start_matrix_run(MATRIX, jobs=2, scheduler=None, resume=False)
        assert stored == set()
        rows = [fake_row(run, matrix_id, index) for index, run in enumerate(MATRIX.runs)]
        for row in rows:
            store.write_run(row)
        store.finish_matrix_run(matrix_id)
        yield store, matrix_id, rows


def test_rows_round_trip_bit_for_bit_with_nan_as_missing(filled):
    store, matrix_id, rows = filled
    frame = store.frame()
    assert list(frame.columns) == list(COLUMN_NAMES)
    assert list(frame["run_key"]) == [row["run_key"] for row in rows]
    for (_, stored), row in zip(frame.iterrows(), rows, strict=True):
        for column in ("energy_max_rel_error", "energy_drift_per_s", "precession_rate_rad_s", "wall_time_s"):
            assert np.float64(stored[column]).tobytes() == np.float64(row[column]).tobytes()
        assert int(stored["nfev"]) == int(row["nfev"])
    assert math.isnan(frame["reference_error"].iloc[0])  # NaN is stored as NULL and read back as NaN


def test_write_run_refuses_unknown_columns_and_duplicates(filled):
    store, matrix_id, rows = filled
    with pytest.raises(ValueError, match="not columns"):
        store.write_run({**rows[0], "colour": "red"})
    with pytest.raises(Exception, match="UNIQUE"):
        store.write_run(rows[0])


def test_provenance_is_recorded(filled):
    store, matrix_id, rows = filled
    runs = store.matrix_runs()
    record = runs.set_index("matrix_id").loc[matrix_id]
    assert record["matrix_name"] == "store_test" and record["status"] == "finished"
    assert record["rows_stored"] == len(rows) and record["ok"] == len(rows)
    assert record["matrix_hash"] == MATRIX.matrix_hash and record["cpu_model"] and record["host"]
    versions = json.loads(record["package_versions"])
    assert {"numpy", "scipy", "numba", "heyoka", "scikit-sundae", "pandas"} <= set(versions)
    assert versions["numpy"] == np.__version__


def test_resume_continues_the_same_matrix_run_and_knows_its_rows(filled):
    store, matrix_id, rows = filled
    resumed_id, stored = store.start_matrix_run(MATRIX, jobs=1, scheduler=None, resume=True)
    assert resumed_id == matrix_id and stored == {row["run_key"] for row in rows}
    fresh_id, stored = store.start_matrix_run(MATRIX, jobs=1, scheduler=None, resume=False)
    assert fresh_id != matrix_id and stored == set()
    assert store.resolve_matrix_id(None) == fresh_id and store.resolve_matrix_id(matrix_id[:-2]) == matrix_id
    assert len(store.frame(all_runs=True)) == len(rows) and store.frame().empty


def test_study_tables_and_adequacy_round_trip(filled):
    store, matrix_id, rows = filled
    study = pd.DataFrame({"kh": [0.1, 0.2], "error": [1e-3, math.inf]})
    store.write_table("stability", study)
    pd.testing.assert_frame_equal(store.read_table("stability"), study)
    store.write_table("stability", study.iloc[:1], replace=False)
    assert len(store.read_table("stability")) == 3
    with pytest.raises(ValueError):
        store.write_table("runs", study)
    with pytest.raises(KeyError, match="stability"):
        store.read_table("no_such_table")
    store.write_adequacy(matrix_id, "seed_2min", [{"model": "spherical", "trajectory_gap": 0.1}])
    store.write_adequacy(matrix_id, "seed_2min", [{"model": "spherical", "trajectory_gap": 0.2, "note": "x"}])
    adequacy = store.adequacy(matrix_id)
    assert list(adequacy["trajectory_gap"]) == [0.2] and list(adequacy["note"]) == ["x"]


def test_compare_finds_a_one_ulp_difference_and_reports_cost_ratios(filled):
    store, matrix_id, rows = filled
    frame = store.frame(matrix_id)
    mismatches, costs, unmatched = compare_runs(frame, frame.copy())
    assert mismatches.empty and not unmatched
    changed = frame.copy()
    changed.loc[1, "reference_error"] = np.nextafter(changed.loc[1, "reference_error"], 1.0)
    changed["wall_time_s"] *= 2.0
    mismatches, costs, unmatched = compare_runs(frame, changed)
    assert list(mismatches["column"]) == ["reference_error"]
    assert mismatches["run"].iloc[0] == f"seed_2min rk4 kh={rows[1]['kh']!r}"
    assert np.allclose(costs["wall_time_s_ratio_b_over_a"], 2.0)
    mismatches, costs, unmatched = compare_runs(frame, frame.iloc[1:])
    assert unmatched == [("A", f"seed_2min rk4 kh={rows[0]['kh']!r}")]
    mismatches, costs, unmatched = compare_runs(frame.iloc[1:], frame)
    assert unmatched == [("B", f"seed_2min rk4 kh={rows[0]['kh']!r}")]


def test_summary_has_one_line_per_scene_and_integrator_with_the_best_error(filled):
    store, matrix_id, rows = filled
    summary = pd.DataFrame(summarize(store.records())).set_index("integrator")
    assert set(summary.index) == {"rk4", "cvode_bdf"}
    assert summary.loc["rk4", "runs"] == 2
    assert summary.loc["rk4", "best_reference_error"] == 1e-4  # the finer of rows 0 (NaN) and 1
    assert summary.loc["rk4", "at"].startswith("kh=0.1")


def test_results_command_lists_exports_and_compares(filled, tmp_path, capsys):
    store, matrix_id, rows = filled
    database = str(store.path)
    assert cli_main(["results", "--db", database]) == 0
    out = capsys.readouterr().out
    assert matrix_id in out and "rk4" in out and "cvode_bdf" in out
    csv, parquet = tmp_path / "rows.csv", tmp_path / "rows.parquet"
    assert cli_main(["results", "--db", database, "--csv", str(csv), "--parquet", str(parquet)]) == 0
    from_csv, from_parquet = pd.read_csv(csv), pd.read_parquet(parquet)
    assert list(from_csv["run_key"]) == list(from_parquet["run_key"]) == [row["run_key"] for row in rows]
    assert from_parquet["energy_max_rel_error"].tolist() == [row["energy_max_rel_error"] for row in rows]
    assert cli_main(["results", "--db", database, "--compare", matrix_id, matrix_id]) == 0
    assert f"identical bit for bit in all {len(rows)} shared runs" in capsys.readouterr().out
    # a second matrix run with one value changed by one ulp: reported, exit status 1
    other_id, _ = store.start_matrix_run(MATRIX, jobs=1, scheduler=None, resume=False)
    for index, row in enumerate(rows):
        changed = {**row, "matrix_id": other_id}
        if index == 2:
            changed["energy_max_rel_error"] = np.nextafter(row["energy_max_rel_error"], 0.0)
        store.write_run(changed)
    assert cli_main(["results", "--db", database, "--compare", matrix_id, other_id]) == 1
    out = capsys.readouterr().out
    assert "1 MISMATCH" in out and "energy_max_rel_error" in out


def test_results_command_without_a_database_exits_2(tmp_path, capsys):
    assert cli_main(["results", "--db", str(tmp_path / "none.sqlite")]) == 2
    err = capsys.readouterr().err
    assert "no results database" in err and "Traceback" not in err


# --- declared facts and schema versions ------------------------------------------------------------------------


def test_rows_carry_the_declared_integrator_facts():
    from foucault_bench.bench.run.execute import base_row
    from foucault_bench.integrators import REGISTRY

    for spec in MATRIX.runs:
        row = base_row(spec, "m")
        integrator = REGISTRY[spec.integrator]
        assert row["family"] == integrator.family and row["declared_order"] == integrator.order
        assert row["adaptive"] == int(integrator.adaptive) and row["stages"] == integrator.stages
        assert row["stability_limit_kh"] == integrator.stability_limit_kh


def _old_database(path, extra_column: str | None = None) -> None:
    """A database as written before the schema was versioned: no declared facts, user_version 0."""
    import sqlite3

    from foucault_bench.bench.schema import COLUMNS, DECLARED_FACTS

    old = [column for column in COLUMNS if column.name == "family" or column.name not in DECLARED_FACTS]
    names = [column.name for column in old] + ([extra_column] if extra_column else [])
    with sqlite3.connect(path) as connection:
        connection.execute(f"CREATE TABLE runs ({', '.join(names)}, PRIMARY KEY (matrix_id, run_key))")
        connection.execute("CREATE TABLE matrix_runs (matrix_id TEXT PRIMARY KEY, matrix_name TEXT, matrix_hash TEXT, "
                           "status TEXT, started_utc TEXT)")
        connection.execute("INSERT INTO matrix_runs VALUES ('old-1', 'old', 'abc', 'finished', "
                           "'2026-01-01T00:00:00+00:00')")
        connection.execute("INSERT INTO runs (run_key, matrix_id, scene, integrator, family, status, reference_error) "
                           "VALUES ('k1', 'old-1', 'seed_2min', 'rk4', 'runge-kutta', 'ok', 1.5e-7)")
    connection.close()


def test_a_new_database_records_the_schema_version(tmp_path):

    with ResultsStore(tmp_path / "new.sqlite") as store:
        assert store.schema_version == SCHEMA_VERSION


def test_an_older_database_is_migrated_and_its_unknown_facts_read_as_missing(tmp_path):

    path = tmp_path / "old.sqlite"
    _old_database(path)
    with ResultsStore(path, create=False) as store:
        assert store.schema_version == SCHEMA_VERSION
        frame = store.frame()
        assert set(COLUMN_NAMES) <= set(frame.columns)
        row = frame.iloc[0]
        assert row["integrator"] == "rk4" and row["reference_error"] == 1.5e-7 and row["family"] == "runge-kutta"
        assert pd.isna(row["declared_order"]) and pd.isna(row["stability_limit_kh"])  # unknown, not guessed
        assert {"cpu_model", "code_version"} <= set(store.matrix_runs().columns)


@pytest.mark.parametrize("case", ["newer version", "unknown column"])
def test_a_database_this_version_cannot_read_is_refused_in_one_line(tmp_path, capsys, case):
    import sqlite3

    path = tmp_path / "other.sqlite"
    if case == "newer version":
        with sqlite3.connect(path) as connection:
            connection.execute("PRAGMA user_version = 99")
        connection.close()
    else:
        _old_database(path, extra_column="colour")
    assert cli_main(["results", "--db", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    expected = "newer than this foucault-bench reads" if case == "newer version" else "does not define (colour)"
    assert len(err) == 1 and expected in err[0]


def test_a_version_2_database_gets_the_scene_keys_its_run_keys_prove(tmp_path):
    """Migration 2 → 3: rows of a built-in scene and of its -azψ variant get that scene's key when their run keys
    hash its present physics (a fixed-step row whose stored step differs from the hashed one inherits its
    scene's proved key); an inline scene, and an inline scene reusing a built-in name with other physics, stay
    NULL (unknown physics). Adequacy rows get their runs' key."""
    import sqlite3

    from foucault_bench.bench.problems.scene_key import scene_key, scene_labels
    from foucault_bench.bench.problems.scenes import SCENES

    import dataclasses

    matrix = parse_matrix({
        "scenes": ["seed_2min"], "integrators": ["rk4", "cvode_bdf"], "kh": [0.2], "tol": [1e-6],
        "release_azimuth_deg": [90, 45], "scene": {"inline": {"base": "seed_2min", "latitude_deg": 10.0}}},
        source="test", default_name="old")
    pantheon = SCENES["pantheon"]  # a built-in name with other physics (as another code version defined it)
    other_pantheon = dataclasses.replace(pantheon, params=dataclasses.replace(pantheon.params, latitude_deg=10.0))
    firsts = {run.integrator: run for run in reversed(matrix.runs)}.values()  # one run per integrator
    runs = [*matrix.runs, *(dataclasses.replace(run, scene=other_pantheon) for run in firsts)]
    path = tmp_path / "old.sqlite"
    with ResultsStore(path) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        for index, run in enumerate(runs):
            row = fake_row(run, matrix_id, index)
            if run.kh is not None and run.scene.name == "seed_2min-az45":
                row["kh"] = np.nextafter(run.kh, 0.0)  # the step taken, not the one in the run key
            store.write_run(row)
            store.write_adequacy(matrix_id, run.scene.name, [{"model": "spherical", "trajectory_gap": 0.1}],
                                 scene_key=scene_key(run.scene))
        store.finish_matrix_run(matrix_id)
    with sqlite3.connect(path) as connection:
        for table in ("runs", "adequacy"):
            connection.execute(f"ALTER TABLE {table} DROP COLUMN scene_key")
        connection.execute("PRAGMA user_version = 2")
    connection.close()

    with ResultsStore(path, create=False) as store:
        assert store.schema_version == SCHEMA_VERSION  # migrated to the present version
        rows = store.frame()
        adequacy = store.adequacy()
    expected = {}
    for run in runs:
        proved = run.scene.name.startswith("seed_2min-az")  # built-in physics (with its azimuth variants)
        expected[run.run_key] = scene_key(run.scene) if proved else None
    got = {key: (value if isinstance(value, str) else None)
           for key, value in zip(rows["run_key"], rows["scene_key"], strict=True)}
    assert got == expected
    assert sum(value is not None for value in got.values()) == 4  # seed_2min-az90 and -az45, 2 runs each
    by_scene = dict(zip(adequacy["scene"], adequacy["scene_key"], strict=True))
    assert by_scene["seed_2min-az45"] == scene_key(matrix.scenes[1]) and pd.isna(by_scene["inline-az45"])
    assert set(scene_labels(rows)) == {"seed_2min-az90", "seed_2min-az45", "inline-az90", "inline-az45",
                                       "pantheon"}  # one physics (known or not) per name: plain names
