"""``foucault-bench advise`` (bench.advise): the recommendation is the cheapest stored run meeting the target,
bad input is exit 2 with one line per problem, --json is one object, and a scene without stored runs gets a
search whose runs are stored."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from foucault_bench.bench.advise import Target, advise
from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.bench.run.matrix import Matrix
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.verdicts.pareto import cost_column
from foucault_bench.bench.run.timing import TimingPolicy
from foucault_bench.bench.schema import COLUMN_NAMES

SCENE = SCENES["seed_2min"]
INTEGRATORS = (("rk4", "runge-kutta", False), ("verlet", "verlet", False), ("heyoka_taylor", "taylor", True),
               ("cvode_bdf", "multistep", True))


def synthetic_store(path: Path, seed: int) -> None:
    """A store holding random rows of ``SCENE`` (one matrix run), some diverged or failed, with adequacy rows."""
    rng = np.random.default_rng(seed)
    matrix = Matrix(name="synthetic", description="", source="test", scenes=(), runs=(), plugins=(),
                    timing=TimingPolicy())
    with ResultsStore(path) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        for number in range(40):
            name, family, adaptive = INTEGRATORS[number % len(INTEGRATORS)]
            row = dict.fromkeys(COLUMN_NAMES)
            setting = float(10 ** rng.uniform(-12, -3)) if adaptive else 2.0 ** -(1 + number // len(INTEGRATORS))
            row.update(run_key=f"k{number}", matrix_id=matrix_id, scene=SCENE.name, model=SCENE.model,
                       integrator=name, family=family, kh=None if adaptive else setting,
                       tol=setting if adaptive else None, duration_s=SCENE.duration_s, n_out=SCENE.n_intervals + 1,
                       status=str(rng.choice(["ok", "ok", "ok", "diverged", "failed"])), message="",
                       reference_error=float(10 ** rng.uniform(-12, -1)),
                       wall_time_s=float(10 ** rng.uniform(-4, 0)), nfev=int(rng.integers(100, 10**6)))
            store.write_run(row)
        store.write_adequacy(matrix_id, SCENE.name, [
            {"model": "spherical", "simpler_model": "linear", "scene_model": "linear",
             "precession_rate_diff": 7.5e-4, "trajectory_gap": 1.5e-4, "note": ""}])
        store.finish_matrix_run(matrix_id)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("target", [1e-3, 1e-6, 1e-9])
def test_no_stored_run_meeting_the_target_is_cheaper_than_the_recommendation(tmp_path: Path, seed: int,
                                                                            target: float) -> None:
    path = tmp_path / "results.sqlite"
    synthetic_store(path, seed)
    with ResultsStore(path, create=False) as store:
        answer = advise(store, SCENE, Target("reference_error", target), search_jobs=None)
        rows = store.frame()
    met = rows[(rows["status"] == "ok") & (rows["reference_error"] <= target)]
    if met.empty:
        assert answer.recommended is None
        return
    chosen = answer.recommended
    assert chosen["reference_error"] <= target
    assert chosen["cost_s"] == met["wall_time_s"].min()  # nothing meeting the target is cheaper
    assert ("kh" in chosen) != ("tol" in chosen)
    costs = [chosen["cost_s"]] + [other["cost_s"] for other in answer.alternatives]
    assert costs == sorted(costs)
    assert len({chosen["integrator"], *(other["integrator"] for other in answer.alternatives)}) == len(costs)
    assert answer.model["needed"] == ("spherical" if target < 1.5e-4 else "linear")


def test_json_answer_is_one_object(tmp_path: Path, capsys) -> None:
    path = tmp_path / "results.sqlite"
    synthetic_store(path, 0)
    code = cli_main(["advise", "--scene", SCENE.name, "--target", "reference_error=1e-3", "--db", str(path),
                     "--json", "--no-search"])
    answer = json.loads(capsys.readouterr().out)
    assert code == 0 and answer["recommended"]["integrator"] in {name for name, _, _ in INTEGRATORS}
    assert {"kh", "tol"} & set(answer["recommended"])
    assert answer["target"] == {"metric": "reference_error", "value": 1e-3}


@pytest.mark.parametrize("arguments, problems", [
    (["--scene", "nowhere", "--target", "reference_error=1e-6"], ["unknown scene 'nowhere'"]),
    (["--scene", "pantheon", "--target", "refrence_error=0"], ["unknown metric 'refrence_error'", "> 0"]),
    (["--scene", "pantheon", "--target", "reference_error=-1e-6"], ["> 0"]),
    (["--scene", "pantheon", "--target", "reference_error"], ["METRIC=VALUE"]),
    (["--scene", "lab_3m", "--target", "analytic_gap_exact=1e-6"], ["does not exist for scene 'lab_3m'"]),
])
def test_bad_input_is_exit_2_with_one_line_per_problem(tmp_path: Path, capsys, arguments: list[str],
                                                      problems: list[str]) -> None:
    assert cli_main(["advise", *arguments, "--db", str(tmp_path / "db.sqlite")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == len(problems)
    for line, problem in zip(lines, problems, strict=True):
        assert line.startswith("foucault-bench advise: error:") and problem in line
    assert not (tmp_path / "db.sqlite").exists()


def test_an_inline_scene_without_runs_is_searched_and_its_runs_stored(tmp_path: Path) -> None:
    matrix_file = tmp_path / "scenes.toml"
    matrix_file.write_text('integrators = ["rk4"]\nkh = [0.1]\n[scene."lab_v1.5"]\nbase = "lab_3m"\n'
                           'duration_s = 20.25\n', encoding="utf-8")
    from foucault_bench.bench.advise import resolve_scene

    scene, problems = resolve_scene("lab_v1.5", str(matrix_file))
    assert not problems
    path = tmp_path / "results.sqlite"
    with ResultsStore(path) as store:
        answer = advise(store, scene, Target("reference_error", 1e-6), integrators=("rk4",))
        rows = store.frame(all_runs=True)
    assert answer.search is not None and answer.search["runs"] == len(rows) <= 4
    assert answer.recommended is not None and answer.recommended["integrator"] == "rk4"
    ok = rows[(rows["status"] == "ok") & (rows["reference_error"] <= 1e-6)]
    assert answer.recommended["cost_s"] == ok[cost_column(rows)].min()  # CPU time where the runs have it
    assert set(rows["scene"]) == {"lab_v1.5"}
