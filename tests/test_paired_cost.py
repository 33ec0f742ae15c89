"""Tests of paired timing (bench/history/paired_cost.py) and ``check --cost-paired`` (bench/gate/paired_cost_gate.py).

Nothing here asserts a time: the workers' answers are checked for their structure (one CPU time per side and
cycle, the runs each side's code reads), and the gate's verdicts are checked on made-up paired times.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pandas as pd
import pytest

from foucault_bench.bench.cli import main
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.gate.paired_cost_gate import paired_cost_outcomes, resolved_revision
from foucault_bench.bench.history.paired_cost import Side, cycle_order, paired_times
from git_repository import one_commit_repository

MATRIX = ('name = "paired"\ndescription = "two short runs"\nscenes = ["seed_2min"]\n'
          'integrators = ["rk4", "dopri5"]\nkh = [0.2]\ntol = [1e-6]\n')
GATE = ('description = "paired gate"\n[[bound]]\nscene = "seed_2min"\nintegrator = "rk4"\nstatus = "ok"\n'
        'basis = "rk4 is stable at this step"\n')


@pytest.fixture
def repository(tmp_path) -> Path:
    return one_commit_repository(tmp_path / "repo")


def test_the_sides_take_turns_and_no_side_always_starts():
    orders = [cycle_order(3, cycle) for cycle in range(3)]
    assert orders == [[0, 1, 2], [1, 2, 0], [2, 0, 1]]
    assert {order[0] for order in orders} == {0, 1, 2}


def test_paired_workers_answer_one_time_per_side_and_cycle(tmp_path):
    """Two workers of the installed code, two process sets of one cycle: every run that is ok on both sides has
    2 positive CPU times per side, and the runs are those the matrix names, in its order."""
    matrix = tmp_path / "paired.toml"
    matrix.write_text(MATRIX, encoding="utf-8")
    identities, times = paired_times(matrix, [Side("a"), Side("b")], cycles=1, process_sets=2)
    assert identities["a"] == identities["b"]  # one code version: the run keys agree too
    assert [(scene, integrator) for scene, integrator, *_ in identities["a"]] == [("seed_2min", "rk4"),
                                                                                 ("seed_2min", "dopri5")]
    assert sorted(times) == [0, 1]
    for samples in times.values():
        assert sorted(samples) == ["a", "b"] and all(len(values) == 2 and min(values) > 0
                                                     for values in samples.values())


def test_a_side_whose_code_is_missing_is_one_line(tmp_path):
    matrix = tmp_path / "paired.toml"
    matrix.write_text(MATRIX, encoding="utf-8")
    with pytest.raises(InputError) as raised:
        paired_times(matrix, [Side("a"), Side("old", source=tmp_path / "empty")], cycles=1)
    assert len(raised.value.problems) == 1 and "side old: its worker ended" in raised.value.problems[0]


def test_the_gate_fails_the_planted_slowdown_and_passes_noise(repository, tmp_path):
    """Made-up paired times (the timing replaced): run 0 is 10 % slower in every pair, run 1 differs by ±1 %
    alternately; only run 0 fails, and both checks name the run and its ratio; run 0's setting is labelled as
    its stored row has it (the step the loop took), run 1, without a row, by the matrix's setting."""
    before = [0.02 * (1 + 0.2 * (index % 3)) for index in range(10)]
    noise = [value * (1.01 if index % 2 else 0.99) for index, value in enumerate(before)]
    new = [["seed_2min", "rk4", 0.2, None, "key-rk4"], ["seed_2min", "dopri5", None, 1e-6, "key-dopri5"]]
    identities = {"baseline": [run[:4] + ["old"] for run in new], "new": new}
    frame = pd.DataFrame({"run_key": ["key-rk4"], "scene": ["seed_2min"], "scene_key": ["k"], "kh": [0.19],
                          "tol": [None], "integrator": ["rk4"]})

    def timer(sides: list[Side], matrix: Path, progress):
        assert (sides[0].source / "foucault_bench" / "f").is_file()  # the revision's checkout
        return identities, {0: {"baseline": before, "new": [value * 1.1 for value in before]},
                            1: {"baseline": before, "new": noise}}

    commit = resolved_revision(repository, "HEAD")
    outcomes = paired_cost_outcomes("quick", frame, repository, "HEAD", commit, first_number=4, timer=timer)
    assert [(outcome.integrator, outcome.passed) for outcome in outcomes] == [("rk4", False), ("dopri5", True)]
    assert [outcome.setting for outcome in outcomes] == ["kh=0.19", "tol=1e-06"]
    assert outcomes[0].measured == pytest.approx(1.1) and outcomes[0].bound.number == 4
    assert "×1.100" in outcomes[0].detail and "10 pairs" in outcomes[0].detail


@pytest.mark.parametrize("extra, message", [
    (["--cost-paired", "nosuch"], "--cost-paired nosuch: not a commit"),
    (["--cost-paired", "HEAD", "--results", "x.sqlite"], "--cost-paired times the matrix's solves"),
])
def test_bad_paired_input_is_one_line(repository, tmp_path, capsys, extra, message):
    gate = tmp_path / "gate.toml"
    gate.write_text(GATE, encoding="utf-8")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main(["check", "--thresholds", str(gate), "--repo", str(repository), *extra])
    error = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(error) == 1 and message in error[0]


def test_a_repo_that_is_not_git_is_one_line(tmp_path):
    with pytest.raises(InputError) as raised:
        resolved_revision(tmp_path, "HEAD")
    assert raised.value.problems == [f"--repo {tmp_path}: not a git repository (no .git in it)"]
