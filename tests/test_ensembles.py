"""Ensembles: declarations refused one line per problem, members expanded and tagged, the summary, the worst
member, advise --worst and the report's ensemble charts recomputed from the stored member rows (plain sqlite3),
and the batches the runner makes of each configuration (``bench.run.ensemble_jobs.run_members``) equal to the
runs alone, a diverging or hanging member its own row."""

from __future__ import annotations

import json
import math
import sqlite3
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.scenes import ENSEMBLES, SCENES
from foucault_bench.bench.run.matrix import load_matrix, parse_matrix
from foucault_bench.bench.schema import VERDICT_COLUMNS

AZIMUTHS = [0.0, 30.0, 60.0, 90.0]
TINY = {
    "name": "tiny_ensemble",
    "integrators": ["verlet", "rk4"],
    "kh": [0.2, 0.1],
    "scene": {"fan": {"base": "seed_2min", "duration_s": 60.0, "ensemble": {"release_azimuth_deg": AZIMUTHS}}},
    "timing": {"min_repeats": 1, "max_repeats": 1, "max_total_s": 0.01},
}
"""A real ensemble run small enough for a test: 4 members of the linear 1-minute scene, 2 methods × 2 steps."""


def problems_of(document: dict) -> list[str]:
    with pytest.raises(InputError) as caught:
        parse_matrix(document, source="m")
    return caught.value.problems


def with_ensemble(ensemble: dict, **scene: object) -> dict:
    return {"integrators": ["rk4"], "kh": [0.2],
            "scene": {"fan": {"base": "lab_3m", "duration_s": 9.0, **scene, "ensemble": ensemble}}}


# --------------------------------------------------------------------------------------------------------------
# declarations
# --------------------------------------------------------------------------------------------------------------
def test_bad_declarations_give_one_line_each() -> None:
    """Empty ranges and lists, an unknown field, members outside the models' limits: one line per problem,
    each naming the scene table, and nothing else."""
    found = problems_of(with_ensemble({"release_azimuth_deg": {"start": 10, "stop": 0, "step": 5},
                                       "latitude_deg": [], "azimut_deg": [1, 2]}))
    assert len(found) == 3 and all("\n" not in line and line.startswith("m: scene.fan: ensemble: ") for line in found)
    assert "range" in found[0] and "is empty" in found[0]
    assert "latitude_deg: the sweep is empty" in found[1]
    assert "unknown field 'azimut_deg'" in found[2] and "did you mean 'release_azimuth_deg'" in found[2]
    outside = problems_of(with_ensemble({"amplitude_m": [0.5, 3.0, 3.5]}))  # L = 3 m: two members outside
    assert len(outside) == 2
    assert all(line.startswith("m: scene.fan: ensemble member amp3") and "less than length_m" in line
               for line in outside)
    (latitude,) = problems_of(with_ensemble({"latitude_deg": [80, 95]}))
    assert latitude.startswith("m: scene.fan: ensemble member lat95: latitude_deg must be within [-90, 90]")


def test_bad_declarations_exit_2_from_the_command_line(tmp_path: Path) -> None:
    matrix = tmp_path / "bad.toml"
    matrix.write_text('integrators = ["rk4"]\nkh = [0.2]\n[scene.fan]\nbase = "lab_3m"\n'
                      '[scene.fan.ensemble]\nlength_m = {start = 1, stop = 2, step = 0}\nspin = [1]\n')
    done = subprocess.run([sys.executable, "-m", "foucault_bench.bench.cli", "run", "--matrix", str(matrix),
                           "--db", str(tmp_path / "db.sqlite")], capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 2 and "Traceback" not in done.stderr
    assert "is empty" in lines[0] and "unknown field 'spin'" in lines[1]
    assert not (tmp_path / "db.sqlite").exists()


def test_members_are_every_combination_named_and_checked() -> None:
    matrix = parse_matrix(with_ensemble({"amplitude_m": {"start": 0.1, "stop": 0.3, "step": 0.1},
                                         "transverse_velocity_m_s": [0.0, 0.01]}, release_azimuth_deg=30.0))
    names = [scene.name for scene in matrix.scenes]
    assert names == ["fan.amp0.1_vt0", "fan.amp0.1_vt0.01", "fan.amp0.2_vt0", "fan.amp0.2_vt0.01",
                     "fan.amp0.3_vt0", "fan.amp0.3_vt0.01"]  # 0.1 + 2·0.1 rounded to the 0.3 written
    member = matrix.scenes[-1]
    assert member.params.amplitude_m == 0.3 and member.ensemble == "fan"
    vx, vy = member.params.release_velocity_m_s  # across the release direction ψ = 30°
    assert vx == pytest.approx(-0.01 * math.sin(math.radians(30))) and vy == pytest.approx(0.01 * math.cos(math.radians(30)))
    row = dict(matrix.runs[0].declared)
    assert row["ensemble"] == "fan" and json.loads(row["ensemble_member"]) == {"amplitude_m": 0.1,
                                                                                "transverse_velocity_m_s": 0.0}
    assert row["ensemble_setting"] == "kh=0.2"


def test_built_in_ensembles_and_their_matrix() -> None:
    azimuths = [dict(scene.member)["release_azimuth_deg"] for scene in ENSEMBLES["lab_3m_azimuths"]]
    assert azimuths == [5.0 * index for index in range(37)]
    latitudes = [scene.params.latitude_deg for scene in ENSEMBLES["pantheon_latitudes"]]
    assert latitudes == [float(value) for value in range(-90, 91, 10)]
    amplitudes = [scene.params.amplitude_m for scene in ENSEMBLES["airy_3m_amplitudes"]]
    assert amplitudes == [round(0.1 * index, 1) for index in range(1, 13)]
    assert not set(SCENES) & {scene.name for members in ENSEMBLES.values() for scene in members}
    matrix = load_matrix("ensembles")
    assert len(matrix.scenes) == 37 + 19 + 12
    assert all(dict(run.declared)["ensemble"] == run.scene.ensemble for run in matrix.runs)


# --------------------------------------------------------------------------------------------------------------
# a real ensemble run, and everything recomputed from its rows
# --------------------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def database(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from foucault_bench.bench.run.runner import run_matrix
    from foucault_bench.bench.run.store import ResultsStore

    path = tmp_path_factory.mktemp("ensemble") / "db.sqlite"
    with ResultsStore(path) as store:
        run_matrix(parse_matrix(TINY, source="tiny"), store, jobs=1, progress=False)
    return path


def stored_rows(path: Path) -> list[dict]:
    connection = sqlite3.connect(path)
    connection.row_factory = sqlite3.Row
    try:
        return [dict(row) for row in connection.execute("SELECT * FROM runs ORDER BY rowid")]
    finally:
        connection.close()


def percentile_type7(values: list[float], percent: float) -> float:
    """Hyndman & Fan's definition 7, written out: h = (n − 1)p, between the order statistics around h."""
    ordered = sorted(values)
    position = (len(ordered) - 1) * percent / 100.0
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (position - low) * (ordered[high] - ordered[low])


def recomputed_summary(rows: list[dict], metric: str) -> dict[tuple[str, str], dict]:
    groups: dict[tuple[str, str], list[dict]] = {}
    for row in rows:
        if row["ensemble"] is not None:
            groups.setdefault((row["integrator"], row["ensemble_setting"]), []).append(row)
    summary = {}
    for key, group in groups.items():
        values = [(row[metric], row["scene"]) for row in group if row[metric] is not None and math.isfinite(row[metric])]
        errors = [value for value, _ in values]
        worst = max(errors)
        summary[key] = {"members": len(group), "median": float(np.median(errors)),
                        "p90": percentile_type7(errors, 90.0), "worst": worst,
                        "worst_member": next(name for value, name in values if value == worst)}
    return summary


def test_member_rows_are_tagged(database: Path) -> None:
    rows = stored_rows(database)
    assert len(rows) == len(AZIMUTHS) * 4
    for row in rows:
        member = json.loads(row["ensemble_member"])
        assert row["ensemble"] == "fan" and row["scene"] == f"fan.az{member['release_azimuth_deg']:g}"
        assert row["ensemble_setting"] in ("kh=0.2", "kh=0.1") and row["status"] == "ok"


@pytest.mark.parametrize("metric", ["reference_error", "precession_rate_ref_error_earth"])
def test_summary_recomputed_from_member_rows(database: Path, metric: str) -> None:
    from foucault_bench.bench.ensembles.summary import ensemble_summary
    from foucault_bench.bench.run.store import ResultsStore

    with ResultsStore(database, create=False) as store:
        table = ensemble_summary(store.frame(), metric)
    expected = recomputed_summary(stored_rows(database), metric)
    assert len(table) == len(expected) == 4
    for line in table.to_dict("records"):
        wanted = expected[(line["integrator"], line["setting"])]
        assert line["members"] == wanted["members"] == len(AZIMUTHS) and line["missing"] == 0
        for column in ("median", "p90", "worst"):
            assert line[column] == pytest.approx(wanted[column], rel=1e-15, abs=0.0)
        assert line["worst_member"] == wanted["worst_member"]


def test_worst_member_named_and_a_failed_member_counted(database: Path) -> None:
    """The worst member is the largest error's; a member without a value is counted as missing, never worst."""
    from foucault_bench.bench.ensembles.summary import ensemble_summary, worst_rows
    from foucault_bench.bench.run.store import ResultsStore

    with ResultsStore(database, create=False) as store:
        frame = store.frame()
    group = frame[(frame["integrator"] == "verlet") & (frame["ensemble_setting"] == "kh=0.2")]
    planted = group.index[1]
    frame.loc[planted, "reference_error"] = 10.0 * frame["reference_error"].max()  # now the worst, by far
    (worst,) = worst_rows(frame[frame.index.isin(group.index)], "reference_error")["scene"]
    assert worst == frame.loc[planted, "scene"]
    frame.loc[planted, ["status", "reference_error"]] = ["failed", math.nan]
    line = ensemble_summary(frame[frame.index.isin(group.index)], "reference_error").iloc[0]
    assert line["missing"] == 1 and line["members"] == len(AZIMUTHS) and line["worst_member"] != worst


def test_advise_worst_against_a_recomputation(database: Path) -> None:
    """The cheapest (integrator, setting) whose worst member meets the target, recomputed from the rows."""
    rows = [row for row in stored_rows(database) if row["status"] == "ok"]
    worst: dict[tuple[str, str], dict] = {}
    for row in rows:
        key = (row["integrator"], row["ensemble_setting"])
        if key not in worst or row["precession_rate_ref_error"] > worst[key]["precession_rate_ref_error"]:
            worst[key] = row
    errors = sorted(row["precession_rate_ref_error"] for row in worst.values())
    target = math.sqrt(errors[1] * errors[2])  # between the second and third worst-member errors: two meet it
    meeting = [row for row in worst.values() if row["precession_rate_ref_error"] <= target]
    expected = min(meeting, key=lambda row: row["cpu_time_s"])
    from foucault_bench.bench.advise.target import Target
    from foucault_bench.bench.advise.worst import advise_worst
    from foucault_bench.bench.run.store import ResultsStore

    members = tuple(parse_matrix(TINY, source="tiny").scenes)
    with ResultsStore(database, create=False) as store:
        answer = advise_worst(store, "fan", members, Target("precession_rate_ref_error", target))
    assert answer.recommended is not None
    assert answer.recommended["integrator"] == expected["integrator"]
    assert answer.recommended["kh"] == expected["kh"]
    assert answer.recommended["worst_member"] == expected["scene"] == answer.scene.name
    assert answer.meeting == len({row["integrator"] for row in meeting})
    from foucault_bench.bench.advise.render import render_text

    assert answer.recommended["batch_members"] == expected["batch_members"] == len(AZIMUTHS)
    assert f"ms (1/{len(AZIMUTHS)} of its batch's)" in render_text(answer).splitlines()[1]


def test_report_charts_read_back_against_the_database(database: Path) -> None:
    """Each ensemble chart's plotly data (what the page embeds) holds the stored members' values."""
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.reports import ensembles, plotly_conversion

    class Recorder:
        def __init__(self) -> None:
            self.charts: dict[str, object] = {}
            self.tables: list[object] = []

        def add(self, *blocks: object) -> None:
            pass

        def table(self, frame, name, title, **_: object) -> None:
            self.tables.append(frame)

        def curves(self, name, caption, draw, table) -> None:
            self.charts[name] = plotly_conversion.from_matplotlib(draw(table))

    with ResultsStore(database, create=False) as store:
        frame = store.frame()
    recorder = Recorder()
    ensembles.add_section(recorder, frame)
    rows = stored_rows(database)
    figure = recorder.charts["ensemble_fan_reference_error"]
    for trace in figure.data:
        integrator, setting = trace["name"].split(" ")
        expected = sorted((json.loads(row["ensemble_member"])["release_azimuth_deg"], row["reference_error"])
                          for row in rows if row["integrator"] == integrator and row["ensemble_setting"] == setting)
        drawn = np.column_stack([np.asarray(trace["x"], dtype=float), np.asarray(trace["y"], dtype=float)])
        np.testing.assert_allclose(drawn, np.array(expected), rtol=1e-12, atol=0.0)
    assert len(figure.data) == 4
    work = recorder.charts["ensemble_fan_work_precision"]
    summary = recomputed_summary(rows, "reference_error")
    worst_by_name = {row["scene"] + row["integrator"] + row["ensemble_setting"]: row for row in rows}
    first_panel = [trace for trace in work.data if trace.get("xaxis") in (None, "x")]
    for trace in first_panel:
        name = trace["name"]
        expected = sorted((worst_by_name[summary[(name, setting)]["worst_member"] + name + setting]
                           ["cpu_time_s"], summary[(name, setting)]["worst"])
                          for integrator, setting in summary if integrator == name)
        drawn = sorted(zip(np.asarray(trace["x"], dtype=float), np.asarray(trace["y"], dtype=float), strict=True))
        np.testing.assert_allclose(np.array(drawn), np.array(expected), rtol=1e-12, atol=0.0)
    assert {trace["name"] for trace in first_panel} == {"verlet", "rk4"}


def same(first: object, second: object) -> bool:
    """Equal, or both missing (None or NaN)."""
    missing = [value is None or (isinstance(value, float) and math.isnan(value)) for value in (first, second)]
    return all(missing) or (not any(missing) and first == second)


def test_run_members_equals_one_by_one_runs() -> None:
    """The batch task: the rows of one configuration's members through ``run_members`` equal, accuracy column
    by column and bit for bit, the rows of the same runs one by one; their cost is the batch's, shared."""
    from foucault_bench.bench.run.ensemble_jobs import configurations, run_members
    from foucault_bench.bench.run.execute import execute_run

    matrix = parse_matrix({**TINY, "integrators": ["verlet"], "kh": [0.2]}, source="tiny")
    (specs,) = configurations(matrix.runs[:2]).values()
    together = run_members(specs, "m")
    alone = [execute_run(spec, "m") for spec in specs]
    for first, second in zip(together, alone, strict=True):
        assert first["status"] == second["status"] == "ok"
        for column in VERDICT_COLUMNS:
            assert same(first[column], second[column]), column
        assert first["batch_members"] == 2 and second["batch_members"] is None
    with pytest.raises(ValueError):
        run_members([matrix.runs[0], parse_matrix({**TINY, "kh": [0.1]}, source="t").runs[0]], "m")


def test_step_energy_false_leaves_out_only_the_per_step_energy_error() -> None:
    """A matrix with ``step_energy = false`` makes no monitored call: its fixed-step rows, alone and in a batch,
    hold no ``energy_max_rel_error_steps`` and every other verdict bit for bit as with the default, which holds a
    finite per-step error; the two matrices hash differently (``--resume`` does not mix their rows)."""
    from foucault_bench.bench.run.ensemble_jobs import configurations, run_members
    from foucault_bench.bench.run.execute import execute_run

    document = {**TINY, "integrators": ["verlet"], "kh": [0.2]}
    with_steps = parse_matrix(document, source="t")
    without = parse_matrix({**document, "step_energy": False}, source="t")
    assert with_steps.step_energy and not without.step_energy and all(not spec.step_energy for spec in without.runs)
    assert with_steps.matrix_hash != without.matrix_hash
    for matrix in (with_steps, without):
        (specs,) = configurations(matrix.runs[:2]).values()
        rows = [*run_members(specs, "m"), execute_run(specs[0], "m")]
        if matrix is with_steps:
            reference_rows = rows
            assert all(math.isfinite(row["energy_max_rel_error_steps"]) for row in rows)
            continue
        for row, reference in zip(rows, reference_rows, strict=True):
            assert row["status"] == reference["status"] == "ok" and row["energy_max_rel_error_steps"] is None
            for column in VERDICT_COLUMNS:
                if column != "energy_max_rel_error_steps":
                    assert same(row[column], reference[column]), column


def rows_alone(matrix) -> dict[str, dict]:
    """Every run of ``matrix`` alone (``execute_run``, as the runner ran runs before batches), by run key."""
    from foucault_bench.bench.run.execute import execute_run

    return {spec.run_key: execute_run(spec, "alone") for spec in matrix.runs}


def test_the_runner_runs_each_configuration_as_one_batch_equal_to_the_runs_alone(database: Path) -> None:
    """Through the runner (``database``: TINY by ``run_matrix``): each member's row is the row of its run alone,
    bit for bit in every accuracy column, counter and step for the fixed-step methods; its cost columns are its
    batch's share (one value for all members of a configuration, ``batch_members`` = the members)."""
    alone = rows_alone(parse_matrix(TINY, source="tiny"))
    stored = stored_rows(database)
    assert {row["run_key"] for row in stored} == set(alone)
    for row in stored:
        expected = alone[row["run_key"]]
        for column in (*VERDICT_COLUMNS, "status", "message", "nfev", "steps", "rejected_steps", "kh", "step_s"):
            assert same(row[column], expected[column]), column
        assert row["batch_members"] == len(AZIMUTHS) and expected["batch_members"] is None
        repeats = json.loads(row["cpu_time_repeats_s"])
        assert len(repeats) == row["repeats"] and row["cpu_time_s"] == pytest.approx(np.median(repeats), rel=1e-12)
    for setting in ("kh=0.2", "kh=0.1"):
        for integrator in ("verlet", "rk4"):
            shares = {(row["cpu_time_s"], row["wall_time_s"], row["compile_time_s"]) for row in stored
                      if row["integrator"] == integrator and row["ensemble_setting"] == setting}
            assert len(shares) == 1


def test_adaptive_batches_through_the_runner_equal_the_runs_alone(tmp_path: Path) -> None:
    """dop853 (a compiled loop over members): bitwise; heyoka_taylor (SIMD lanes): the same step counts, every
    error equal to round-off (relative 1e-9 of errors that are themselves ≥ 1e-12, far above the 1e-13 of the
    state scale that ``tests/test_batch.py`` bounds the states' difference by)."""
    from foucault_bench.bench.run.runner import run_matrix
    from foucault_bench.bench.run.store import ResultsStore

    matrix = parse_matrix({key: value for key, value in {**TINY, "integrators": ["dop853", "heyoka_taylor"],
                                                           "tol": [1e-8]}.items() if key != "kh"}, source="tiny")
    with ResultsStore(tmp_path / "db.sqlite") as store:
        run_matrix(matrix, store, jobs=1, progress=False)
    alone = rows_alone(matrix)
    for row in stored_rows(tmp_path / "db.sqlite"):
        expected = alone[row["run_key"]]
        assert row["status"] == expected["status"] == "ok" and row["batch_members"] == len(AZIMUTHS)
        assert (row["nfev"], row["steps"]) == (expected["nfev"], expected["steps"])
        for column in VERDICT_COLUMNS:
            if row["integrator"] == "dop853" or row[column] is None:
                assert same(row[column], expected[column]), column
            else:
                assert row[column] == pytest.approx(expected[column], rel=1e-9, abs=1e-15), column


PICKY = '''
"""A test-only integrator (registered when imported): dop853's solution, except for chosen release azimuths."""
import ctypes
from typing import ClassVar

from foucault_bench.integrators import get_integrator, register
from foucault_bench.integrators.adaptive import AdaptiveIntegrator
from foucault_bench.integrators.base import Solution

DIVERGES_AT_DEG = 30.0
HANGS_AT_DEG = 90.0


@register
class Picky(AdaptiveIntegrator):
    name: ClassVar[str] = "test_picky"
    family: ClassVar[str] = "test"
    order: ClassVar[None] = None
    reference: ClassVar[str] = "tests/test_ensembles.py"

    def _solve(self, problem, *, step_s, tol, monitor):
        azimuth = problem.params.release_azimuth_deg
        if azimuth == DIVERGES_AT_DEG:
            return Solution.failure(problem.t_out, "left the sphere", status="diverged")
        while azimuth == HANGS_AT_DEG:  # a C sleep that holds the GIL (ctypes.PyDLL): only ending the process stops it; no CPU used
            ctypes.PyDLL(None).sleep(3600)
        return get_integrator("dop853").solve(problem, tol=tol, monitor=monitor)
'''


HANG_LIMIT_S = 15.0
"""The time limit of the hanging batch: above the 30-s scene's dop853 run with a cold compile cache on a loaded
2-core machine (5 s was too short at load average 19), and what the test waits twice (batch, then alone)."""


@pytest.fixture
def picky_plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """An importable plug-in module (workers get the parent's sys.path), removed again after the test."""
    from foucault_bench.integrators import unregister

    module_name = f"picky_integrator_{tmp_path.name}"
    (tmp_path / f"{module_name}.py").write_text(PICKY, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield module_name
    unregister("test_picky")
    sys.modules.pop(module_name, None)


def test_a_diverging_or_hanging_member_is_its_own_row_and_the_others_keep_theirs(tmp_path: Path,
                                                                                 picky_plugin: str) -> None:
    """In one batch: the member that diverges is its row alone (diverged, no cost, as a run alone has), the two
    that end ok are a batch of 2. With a member that hangs, the batch passes the time limit, and its members run
    one by one: the hanging one is a timeout row, the others are ok rows timed alone."""
    from foucault_bench.bench.run.runner import run_matrix
    from foucault_bench.bench.run.store import ResultsStore

    document = {"integrators": ["test_picky"], "tol": [1e-6], "plugins": [picky_plugin],
                "scene": {"fan": {"base": "seed_2min", "duration_s": 60.0,  # TINY's references
                                  "ensemble": {"release_azimuth_deg": [0.0, 30.0, 60.0]}}},
                "timing": {"min_repeats": 1, "max_repeats": 1, "run_timeout_s": 20.0}}
    with ResultsStore(tmp_path / "diverges.sqlite") as store:
        run_matrix(parse_matrix(document, source="picky"), store, jobs=1, progress=False)
    rows = {row["scene"]: row for row in stored_rows(tmp_path / "diverges.sqlite")}
    assert rows["fan.az30"]["status"] == "diverged" and rows["fan.az30"]["message"] == "left the sphere"
    assert rows["fan.az30"]["batch_members"] is None and rows["fan.az30"]["cpu_time_s"] is None
    for name in ("fan.az0", "fan.az60"):
        assert rows[name]["status"] == "ok" and rows[name]["batch_members"] == 2 and rows[name]["cpu_time_s"] > 0
    hanging = {**document, "scene": {"fan": {**document["scene"]["fan"],
                                             "ensemble": {"release_azimuth_deg": [0.0, 90.0]}}},
               "timing": {**document["timing"], "run_timeout_s": HANG_LIMIT_S}}
    with ResultsStore(tmp_path / "hangs.sqlite") as store:
        run_matrix(parse_matrix(hanging, source="picky"), store, jobs=1, progress=False)
    rows = {row["scene"]: row for row in stored_rows(tmp_path / "hangs.sqlite")}
    assert rows["fan.az90"]["status"] == "timeout" and f"{HANG_LIMIT_S:g} s" in rows["fan.az90"]["message"]
    assert rows["fan.az0"]["status"] == "ok" and rows["fan.az0"]["batch_members"] is None


def test_advise_worst_refuses_a_scene_that_is_no_ensemble(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "foucault_bench.bench.cli", "advise", "--scene", "lab_3m",
                           "--target", "reference_error=1e-6", "--worst", "--db", str(tmp_path / "db.sqlite")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert "with --worst, 'lab_3m' must be an ensemble" in line and "lab_3m_azimuths" in line


def test_a_version_4_database_gets_the_ensemble_columns(tmp_path: Path) -> None:
    """Schema 4 → now: the runs table gains ensemble, ensemble_member, ensemble_setting and batch_members, NULL
    in the old rows (none of which was an ensemble member or timed in a batch), and the file records the present
    version."""
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.schema import COLUMNS, MIGRATIONS, SCHEMA_VERSION

    added = ("ensemble", "ensemble_member", "ensemble_setting")
    assert all(name in MIGRATIONS[4] for name in added) and "batch_members" in MIGRATIONS[4]
    path = tmp_path / "v4.sqlite"
    old = [f"{column.name} {column.sql_type}" for column in COLUMNS if column.name not in (*added, "batch_members")]
    with sqlite3.connect(path) as connection:
        connection.execute(f"CREATE TABLE runs ({', '.join(old)}, PRIMARY KEY (matrix_id, run_key))")
        connection.execute("CREATE TABLE matrix_runs (matrix_id TEXT PRIMARY KEY, matrix_name TEXT, matrix_hash TEXT, "
                           "status TEXT, started_utc TEXT, code_version TEXT)")
        connection.execute("INSERT INTO matrix_runs VALUES ('old-1', 'old', 'abc', 'finished', "
                           "'2026-01-01T00:00:00+00:00', 'v')")
        connection.execute("INSERT INTO runs (run_key, matrix_id, scene, integrator, status, reference_error) "
                           "VALUES ('k1', 'old-1', 'seed_2min', 'rk4', 'ok', 1.5e-7)")
        connection.execute("PRAGMA user_version = 4")
    connection.close()
    with ResultsStore(path, create=False) as store:
        assert store.schema_version == SCHEMA_VERSION
        row = store.frame().iloc[0]
    assert all(row[name] is None or row[name] != row[name] for name in (*added, "batch_members"))
    with sqlite3.connect(path) as connection:
        stored = {line[1] for line in connection.execute("PRAGMA table_info(runs)")}
    connection.close()
    assert {*added, "batch_members"} <= stored


def test_members_get_no_scene_page_or_recommendation_of_their_own(database: Path) -> None:
    """The per-scene sections cover the scenes of their own; an ensemble's members are in its own section."""
    from types import SimpleNamespace
    from unittest.mock import MagicMock

    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.reports import result_sections

    with ResultsStore(database, create=False) as store:
        frame = store.frame()
    member = frame["scene"].iloc[0]
    alone = frame[frame["scene"] == member].copy()
    alone["scene"], alone["ensemble"] = "alone", None
    runs = pd.concat([frame, alone], ignore_index=True)
    inputs = SimpleNamespace(runs=runs, targets=(1e-3,))
    pages = MagicMock()
    result_sections.scene_pages(pages, inputs)
    assert [call.args[1] for call in pages.page.call_args_list] == ["scene alone"]
    front = MagicMock()
    result_sections.recommendations(front, inputs)
    assert [call.args[1] for call in front.table.call_args_list] == ["recommendation_alone"]
    assert frame["ensemble"].notna().all() and len(set(frame["scene"])) > 1


def test_resuming_a_half_stored_ensemble_runs_only_the_missing_members(database: Path, tmp_path: Path) -> None:
    """A matrix run that ended with some members of an ensemble stored and others not (a power cut between two
    batches): ``--resume`` runs the missing members only, leaves the stored rows as they were, and ends with
    every member once, with the errors of the uninterrupted run (the fixed-step members are bitwise the
    one-by-one solutions, so a batch of fewer members gives the same numbers)."""
    from foucault_bench.bench.run.runner import run_matrix
    from foucault_bench.bench.run.store import ResultsStore

    path = tmp_path / "half.sqlite"
    shutil.copyfile(database, path)
    complete = {row["run_key"]: row for row in stored_rows(database)}
    dropped = [key for key, row in complete.items()
               if (row["integrator"], row["scene"]) in {("verlet", "fan.az30"), ("rk4", "fan.az0"), ("rk4", "fan.az90")}]
    assert 0 < len(dropped) < len(complete)
    with sqlite3.connect(path) as connection:
        connection.executemany("DELETE FROM runs WHERE run_key = ?", [(key,) for key in dropped])
        connection.execute("UPDATE matrix_runs SET status = 'running'")
    connection.close()
    kept_before = {row["run_key"]: row for row in stored_rows(path)}
    with ResultsStore(path) as store:
        run_matrix(parse_matrix(TINY, source="tiny"), store, jobs=1, resume=True, progress=False)
        assert store.matrix_runs()["status"].tolist() == ["finished"]
    rows = stored_rows(path)
    assert sorted(row["run_key"] for row in rows) == sorted(complete)  # every member once
    resumed = {row["run_key"]: row for row in rows}
    assert all(resumed[key] == row for key, row in kept_before.items())  # the stored rows untouched
    for key in dropped:
        assert resumed[key]["status"] == complete[key]["status"] == "ok"
        for column in (*VERDICT_COLUMNS, "nfev", "steps", "ensemble", "ensemble_member"):
            assert same(resumed[key][column], complete[key][column]), (key, column)
