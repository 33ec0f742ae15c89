"""Tests of the history across revisions (bench/history/), ``check --baseline`` and ``bisect``.

The fixture database holds four revisions of the report's fixture run (``tests/report_fixture.py``: four scenes of
three models, an inline scene, failed and diverged runs): its rows under a first commit, then copies under three more commits with planted differences: an accuracy change at the second (one
row's precession error moved by one ulp), a cost change at the third (one run's timed repeats 25 % slower), and
noise only at the fourth (every run's repeats drawn again from the same distribution). History must report
exactly the two planted changes, ``check --baseline`` must exit 1 on the accuracy change (0 once it is declared
expected) and 0 on noise, and bisection on a temporary git repository with a planted change must name that
commit. Timed repeats are made-up numbers from a seeded generator: nothing here measures time.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import sqlite3
import subprocess

import numpy as np
import pytest

from foucault_bench.bench.cli import main
from foucault_bench.bench.history.bisect import Configuration, bisect
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.history.changes import (
    COST_MIN_EFFECT, MIN_PAIRS, CostComparison, cost_change, history_changes, lined_up, paired_cost_change,
)
from foucault_bench.bench.history.load import load_history
from foucault_bench.bench.history.revisions import ordered_revisions
from foucault_bench.reports.history_page import HISTORY_COLUMNS
from git_repository import git, one_commit_repository

COMMITS = ["1" * 40, "2" * 40, "3" * 40, "4" * 40]
PLANTED_ACCURACY = ("rk4", "precession_rate_ref_error")
PLANTED_COST = "verlet"
SLOWDOWN = 1.25
REPEATS = 8
NOISE = 0.02


def run_cli(argv: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main(argv)
    return status, out.getvalue()


def _repeats(rng: np.random.Generator, median_s: float) -> str:
    return json.dumps([float(median_s * math.exp(NOISE * value)) for value in rng.standard_normal(REPEATS)])


@pytest.fixture(scope="module")
def history_db(tmp_path_factory) -> dict:
    from report_fixture import build_fixture_database

    folder = tmp_path_factory.mktemp("history")
    db = build_fixture_database(folder / "history.sqlite")
    rng = np.random.default_rng(20261202)
    connection = sqlite3.connect(db)
    with connection:
        (first,) = connection.execute("SELECT matrix_id FROM matrix_runs").fetchone()
        columns = [row[1] for row in connection.execute("PRAGMA table_info(runs)")]
        run_columns = [row[1] for row in connection.execute("PRAGMA table_info(matrix_runs)")]
        base_rows = [dict(zip(columns, row, strict=True)) for row in
                     connection.execute("SELECT * FROM runs WHERE matrix_id = ? ORDER BY rowid", (first,))]
        base_run = connection.execute("SELECT * FROM matrix_runs WHERE matrix_id = ?", (first,)).fetchone()
        accuracy_row = next(row["run_key"] for row in base_rows if row["integrator"] == PLANTED_ACCURACY[0]
                            and row["scene"] == "pantheon" and row["status"] == "ok")
        cost_row = next(row["run_key"] for row in base_rows if row["integrator"] == PLANTED_COST
                        and row["scene"] == "lab_3m" and row["status"] == "ok")
        connection.execute("DELETE FROM runs")
        ids = []
        for number, commit in enumerate(COMMITS):
            matrix_id = first if number == 0 else f"{first}-r{number + 1}"
            if number:
                record = dict(zip(run_columns, base_run, strict=True))
                record.update(matrix_id=matrix_id, code_version=f"{number + 1:016d}")
                connection.execute(f"INSERT INTO matrix_runs ({', '.join(record)}) VALUES "
                                   f"({', '.join('?' * len(record))})", list(record.values()))
            ids.append(matrix_id)
            connection.execute("UPDATE matrix_runs SET git_commit = ?, cpu_model = 'test cpu', started_utc = ? "
                               "WHERE matrix_id = ?", (commit, f"2026-11-0{number + 1}T00:00:00+00:00", matrix_id))
            for base in base_rows:
                record = dict(base)
                slower = SLOWDOWN if number >= 2 and base["run_key"] == cost_row else 1.0
                timed = base["cpu_time_s"] is not None
                record.update(matrix_id=matrix_id, run_key=f"{base['run_key']}-{number}",
                              cpu_time_repeats_s=_repeats(rng, base["cpu_time_s"] * slower) if timed else None,
                              calibration_cpu_s=0.1 if timed else None, cpu_time_ci95_rel=None)
                if number >= 1 and base["run_key"] == accuracy_row:
                    record[PLANTED_ACCURACY[1]] = float(np.nextafter(base[PLANTED_ACCURACY[1]], math.inf))
                connection.execute(f"INSERT INTO runs ({', '.join(record)}) VALUES ({', '.join('?' * len(record))})",
                                   list(record.values()))
        settings = {key: next(row for row in base_rows if row["run_key"] == key) for key in (accuracy_row, cost_row)}
    connection.close()
    thresholds = folder / "gate.toml"
    thresholds.write_text('description = "history fixture gate"\n[[bound]]\nscene = "pantheon"\nintegrator = "rk4"\n'
                          'status = "ok"\nbasis = "rk4 is stable at these steps"\n', encoding="utf-8")
    from foucault_bench.bench.schema import setting_label

    planted = {name: setting_label(settings[key]["kh"], settings[key]["tol"])
               for name, key in (("accuracy", accuracy_row), ("cost", cost_row))}
    return {"db": db, "ids": ids, "thresholds": thresholds, "folder": folder, "settings": planted,
            "accuracy_kh": settings[accuracy_row]["kh"]}


def test_history_reports_exactly_the_two_planted_changes(history_db):
    history = load_history(history_db["db"])
    assert [revision.git_commit for revision in history.revisions] == COMMITS
    found = [(change.kind, change.scene, change.integrator, change.setting, change.column, change.after_revision)
             for change in history.changes]
    settings = history_db["settings"]
    assert sorted(found) == sorted([
        ("accuracy", "pantheon", PLANTED_ACCURACY[0], settings["accuracy"], PLANTED_ACCURACY[1],
         history.revisions[1].label),
        ("cost", "lab_3m", PLANTED_COST, settings["cost"], "cpu_time_s", history.revisions[2].label),
    ])


def test_history_page_draws_the_rows(history_db, tmp_path):
    out = tmp_path / "history"
    status, printed = run_cli(["history", "--db", str(history_db["db"]), "--out", str(out)])
    assert status == 0 and "2 change(s)" in printed
    page = (out / "history.html").read_text(encoding="utf-8")
    history = load_history(history_db["db"])
    charts = [json.loads(chunk.split(">", 1)[1].split("</script>", 1)[0])
              for chunk in page.split('<script type="application/json"')[1:]]
    assert charts
    stored = {(row["scene_label"], row["integrator"], row["setting"], row["revision"]): row
              for row in history.rows.to_dict("records")}
    drawn = 0
    for chart in charts:
        column = chart["layout"]["yaxis"]["title"]["text"]
        scene = chart["layout"]["title"]["text"].split(":")[0]
        for trace in chart["data"]:
            integrator, setting = trace["name"].split(" ")
            for label, y in zip(trace["x"], trace["y"], strict=True):
                row = stored.get((scene, integrator, setting, label))
                value = float(row[column]) if row is not None and row[column] is not None else math.nan
                assert (y is None and not (value > 0)) or y == value  # the database value, bit for bit
                drawn += y is not None
    # every positive stored value of a drawn column is on its chart
    expected = sum(1 for row in stored.values() for column in HISTORY_COLUMNS
                   if row[column] is not None and float(row[column]) > 0)
    assert drawn == expected


def test_check_baseline_fails_on_the_accuracy_change_and_passes_on_noise(history_db):
    db, ids, gate = str(history_db["db"]), history_db["ids"], str(history_db["thresholds"])
    accuracy, _ = run_cli(["check", "--thresholds", gate, "--results", db, "--matrix-id", ids[1],
                           "--baseline", f"{db}:{ids[0]}"])
    noise, _ = run_cli(["check", "--thresholds", gate, "--results", db, "--matrix-id", ids[3],
                        "--baseline", f"{db}:{ids[2]}", "--cost"])
    cost, printed = run_cli(["check", "--thresholds", gate, "--results", db, "--matrix-id", ids[2],
                             "--baseline", f"{db}:{ids[1]}", "--cost"])
    assert (accuracy, noise, cost) == (1, 0, 1)
    assert PLANTED_COST in printed.split("Failed")[1]


def test_an_expected_change_passes(history_db, tmp_path):
    gate = tmp_path / "expected.toml"
    gate.write_text(history_db["thresholds"].read_text(encoding="utf-8") +
                    f'[[expected_change]]\nscene = "pantheon"\nintegrator = "{PLANTED_ACCURACY[0]}"\n'
                    f'kh = {history_db["accuracy_kh"]!r}\n'
                    f'columns = ["{PLANTED_ACCURACY[1]}"]\nbasis = "planted"\n', encoding="utf-8")
    db, ids = str(history_db["db"]), history_db["ids"]
    status, _ = run_cli(["check", "--thresholds", str(gate), "--results", db, "--matrix-id", ids[1],
                         "--baseline", f"{db}:{ids[0]}"])
    assert status == 0


def test_cost_change_needs_effect_and_evidence():
    import pandas as pd

    def row(samples: list[float]) -> pd.Series:
        return pd.Series({"cpu_time_repeats_s": json.dumps(samples), "calibration_cpu_s": 1.0,
                          "cpu_time_ci95_rel": None})

    rng = np.random.default_rng(7)
    base = list(1 + 0.01 * rng.standard_normal(10))
    small = [value * (1 + COST_MIN_EFFECT / 2) for value in base]
    large = [value * 1.2 for value in base]
    assert not cost_change(row(base), row(small)).changed  # significant but under the effect size
    comparison = cost_change(row(base), row(large))
    assert isinstance(comparison, CostComparison) and comparison.changed and comparison.p_value < 0.01
    few = cost_change(row(base[:3]), row([value * 1.2 for value in base[3:6]]))
    assert few is not None and few.changed and few.p_value is None and few.method.startswith("beyond both intervals")
    assert cost_change(row(base), pd.Series({"cpu_time_repeats_s": None})) is None


def test_a_cost_change_must_exceed_both_runs_noise_and_calibration_applies_between_machines():
    """A 10 % ratio is a change between two steady runs (half-widths 1 % each) and not between two runs whose
    repeats scatter by ±8 % (their intervals overlap); on one machine the repeats are compared as measured,
    between two CPU models divided by each row's calibration."""
    import pandas as pd

    def row(samples: list[float], *, calibration_s: float = 1.0, cpu: str = "cpu A") -> pd.Series:
        return pd.Series({"cpu_time_repeats_s": json.dumps(samples), "calibration_cpu_s": calibration_s,
                          "cpu_time_ci95_rel": None, "cpu_model": cpu})

    steady = [1.0 + 0.01 * offset for offset in (-1, -0.5, 0, 0.5, 1, 0.2, -0.2)]
    scattered = [1.0 + 0.08 * offset for offset in (-1, -0.5, 0, 0.5, 1, 0.2, -0.2)]
    assert cost_change(row(steady), row([value * 1.1 for value in steady])).changed
    assert not cost_change(row(scattered), row([value * 1.1 for value in scattered])).changed
    same_machine = cost_change(row(steady), row(steady, calibration_s=2.0))
    assert same_machine.ratio == 1.0 and not same_machine.changed and same_machine.method.endswith("one machine")
    faster_machine = cost_change(row(steady), row([value / 2 for value in steady], calibration_s=0.5, cpu="cpu B"))
    assert faster_machine.ratio == pytest.approx(1.0) and not faster_machine.changed
    assert faster_machine.method.endswith("calibrated")


def _session(rng: np.random.Generator, pairs: int) -> tuple[list[float], list[float]]:
    """Made-up paired times: each cycle's machine factor (log-normal, σ 20 %, as the adaptive drivers moved
    between rounds) multiplies both sides alike; each solve has its own 2 % scatter."""
    machine = np.exp(0.2 * rng.standard_normal(pairs))
    return ([float(value) for value in 0.05 * machine * np.exp(0.02 * rng.standard_normal(pairs))],
            [float(value) for value in 0.05 * machine * np.exp(0.02 * rng.standard_normal(pairs))])


def test_the_paired_rule_finds_a_planted_slowdown_and_passes_noise():
    """200 seeded sessions of 10 pairs whose machine factor moves by 20 % between cycles: with the same code on
    both sides at most 1 % is flagged (the effect floor, 5 %, is 2.5 σ of one pair's log-ratio, and the median of
    10 pairs narrows it further); with the second side 10 % slower every session is found slower. The unpaired
    rule on the same numbers (the repeats of each side as a run) finds under a tenth of the slowdowns: the
    machine's scatter hides them."""
    rng = np.random.default_rng(20261202)
    flagged = found = unpaired_found = 0
    for _ in range(200):
        before, after = _session(rng, 10)
        flagged += paired_cost_change(before, after).changed
        slower = [value * 1.1 for value in after]
        comparison = paired_cost_change(before, slower)
        found += comparison.changed and comparison.ratio > 1
        unpaired = cost_change({"cpu_time_repeats_s": json.dumps(before), "calibration_cpu_s": 1.0},
                               {"cpu_time_repeats_s": json.dumps(slower), "calibration_cpu_s": 1.0})
        unpaired_found += unpaired is not None and unpaired.changed
    assert flagged <= 2 and found == 200 and unpaired_found < 20


def test_the_paired_rule_reports_the_median_ratio_and_the_effect_floor():
    """Every pair 3 % slower: significant (p = 2/2¹⁰) but under the 5 % floor, so not a change; 8 % faster: a
    change with ratio 1/1.08 exactly; identical samples: ratio 1 and p = 1."""
    before = [0.01 * (1 + 0.1 * index) for index in range(10)]
    small = paired_cost_change(before, [value * (1 + COST_MIN_EFFECT - 0.02) for value in before])
    assert not small.changed and small.p_value < 0.01 and small.method.startswith("paired")
    faster = paired_cost_change(before, [value / 1.08 for value in before])
    assert faster.changed and faster.ratio == pytest.approx(1 / 1.08)
    same = paired_cost_change(before, before)
    assert same.ratio == 1.0 and same.p_value == 1.0 and not same.changed


@pytest.mark.parametrize("before, after, message", [
    ([0.01] * MIN_PAIRS, [0.01] * (MIN_PAIRS + 1), "pairs need as many"),
    ([0.01] * (MIN_PAIRS - 1), [0.01] * (MIN_PAIRS - 1), f"at least {MIN_PAIRS}"),
    ([0.01] * (MIN_PAIRS - 1) + [0.0], [0.01] * MIN_PAIRS, "positive finite"),
    ([0.01] * (MIN_PAIRS - 1) + [math.nan], [0.01] * MIN_PAIRS, "positive finite"),
])
def test_the_paired_rule_refuses_bad_samples_in_one_line(before, after, message):
    with pytest.raises(InputError) as raised:
        paired_cost_change(before, after)
    assert len(raised.value.problems) == 1 and message in raised.value.problems[0]


def test_revisions_fall_back_to_time_without_the_repository(history_db, tmp_path):
    from foucault_bench.bench.run.store import ResultsStore

    with ResultsStore(history_db["db"], create=False) as store:
        runs = store.matrix_runs()
    shuffled = runs.iloc[::-1].copy()
    revisions, how = ordered_revisions(shuffled, source="x", repository=tmp_path)
    assert how.startswith("time") and [revision.git_commit for revision in revisions] == COMMITS
    with ResultsStore(history_db["db"], create=False) as store:
        frame = store.frame(all_runs=True)
    assert len(history_changes(lined_up(frame, revisions))) == 2


@pytest.mark.parametrize("argv, message", [
    (["history", "--scene", "nowhere"], "--scene 'nowhere': no stored row has it"),
    (["history", "--integrator", "rk5"], "--integrator 'rk5': no stored row has it (did you mean 'rk4'?)"),
    (["check", "--cost"], "--cost compares costs with a baseline"),
    (["history", "--repo", "/no/such/repository"], "--repo /no/such/repository: not a git repository"),
])
def test_bad_history_input_is_one_line(history_db, capsys, argv, message):
    command = argv[0]
    extra = ["--db", str(history_db["db"])] if command == "history" else \
        ["--thresholds", str(history_db["thresholds"]), "--results", str(history_db["db"])]
    status, _ = run_cli([*argv[:1], *extra, *argv[1:]])
    error = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(error) == 1 and message in error[0]



def test_history_never_replaces_the_repository_it_reads(history_db, tmp_path, capsys):
    """``--out`` naming the ``--repo`` folder (or a folder holding it) is refused even with ``--force``: replacing
    it would delete the repository, ``.git`` included."""
    repository = tmp_path / "project" / "repository"
    repository.mkdir(parents=True)
    subprocess.run(["git", "init", "-q", str(repository)], check=True)
    for out in (repository, repository.parent):
        status, _ = run_cli(["history", "--db", str(history_db["db"]), "--repo", str(repository), "--out", str(out),
                             "--force"])
        error = capsys.readouterr().err.strip().splitlines()
        assert status == 2 and len(error) == 1 and "holds --repo" in error[0], error
        assert (repository / ".git" / "HEAD").is_file()

def test_a_database_without_provenance_is_refused(history_db, tmp_path, capsys):
    copy = tmp_path / "bare.sqlite"
    copy.write_bytes(history_db["db"].read_bytes())
    with sqlite3.connect(copy) as connection:
        connection.execute("UPDATE matrix_runs SET git_commit = NULL, code_version = NULL")
    status, _ = run_cli(["history", "--db", str(copy)])
    error = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(error) == 1 and "record no code version and no git commit" in error[0]


def test_baseline_with_other_physics_is_refused(history_db, tmp_path, capsys):
    copy = tmp_path / "other.sqlite"
    copy.write_bytes(history_db["db"].read_bytes())
    ids = history_db["ids"]
    with sqlite3.connect(copy) as connection:
        connection.execute("UPDATE runs SET scene_key = 'ffffffffffffffff' WHERE matrix_id = ? AND scene = 'pantheon'",
                           (ids[0],))
    status, _ = run_cli(["check", "--thresholds", str(history_db["thresholds"]), "--results", str(copy),
                         "--matrix-id", ids[1], "--baseline", f"{copy}:{ids[0]}"])
    error = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(error) == 1 and "other physics" in error[0]


def test_bisect_names_the_planted_commit(tmp_path):
    """A repository of eight commits whose file ``value`` holds the verdict; the value changes at commit 6.
    ``measure`` reads the file at a commit (the search itself, not the per-commit runs, is what is tested)."""
    repository = tmp_path / "repo"
    repository.mkdir()
    git(repository, "init", "-q")
    commits = []
    for number in range(8):
        (repository / "value").write_text("1.0" if number < 6 else "1.5", encoding="utf-8")
        (repository / "log").write_text(str(number), encoding="utf-8")
        git(repository, "add", "-A")
        git(repository, "commit", "-q", "-m", f"commit {number}")
        commits.append(git(repository, "rev-parse", "HEAD"))

    def measure(commit: str) -> object:
        if commit == commits[4]:
            raise RuntimeError("cannot be built")  # a skipped commit is stepped over
        return float(git(repository, "show", f"{commit}:value"))

    configuration = Configuration("short", "rk4", "reference_error", kh=0.1)
    answer = bisect(repository, commits[0], commits[7], configuration, measure=measure)
    assert answer.first_changed == commits[6] and answer.last_unchanged == commits[5]
    assert (answer.value_before, answer.value_after) == (1.0, 1.5)
    assert len(answer.tested) < 8  # halved, not every commit


def test_bisect_refuses_an_unknown_revision(tmp_path, capsys):
    repository = one_commit_repository(tmp_path / "repo")
    status, _ = run_cli(["bisect", "--repo", str(repository), "--good", "nosuch", "--bad", "HEAD", "--scene", "s",
                         "--integrator", "rk4", "--kh", "0.1", "--verdict", "reference_error"])
    error = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(error) == 1 and "--good nosuch: not a commit" in error[0]


def test_a_report_of_a_database_of_several_revisions_links_its_history_page(history_db, tmp_path, monkeypatch):
    """The report's overview links history/history.html when the database holds more than one revision, and the
    page written there is the history of the database (the figure drawing is replaced: it is tested elsewhere)."""
    import foucault_bench.reports.build as build
    from foucault_bench.reports.builder import Builder
    from foucault_bench.reports.html_page import write_pages
    from foucault_bench.reports.result_sections import overview

    seen = {}

    def overview_only(inputs, folder, progress=False, previous=None):
        seen["revisions"] = inputs.revisions
        builder = Builder(folder, False, False)
        overview(builder, inputs)
        return write_pages(folder, "test", builder.pages)

    monkeypatch.setattr(build, "build_report", overview_only)
    out = tmp_path / "report"
    assert build.write_report(history_db["db"], None, out, studies="skip") == 0
    assert seen["revisions"] == len(COMMITS)
    assert "href='history/history.html'" in (out / "index.html").read_text(encoding="utf-8")
    assert "(history/history.html)" in (out / "REPORT.md").read_text(encoding="utf-8")
    page = (out / "history" / "history.html").read_text(encoding="utf-8")
    assert f"{len(COMMITS)} revisions" in page and "2 change(s)" in page
