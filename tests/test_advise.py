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
from foucault_bench.bench.problems.scene_key import scene_key
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
            row.update(run_key=f"k{number}", matrix_id=matrix_id, scene=SCENE.name, scene_key=scene_key(SCENE),
                       model=SCENE.model,
                       integrator=name, family=family, kh=None if adaptive else setting,
                       tol=setting if adaptive else None, duration_s=SCENE.duration_s, n_out=SCENE.n_intervals + 1,
                       status=str(rng.choice(["ok", "ok", "ok", "diverged", "failed"])), message="",
                       reference_error=float(10 ** rng.uniform(-12, -1)),
                       wall_time_s=float(10 ** rng.uniform(-4, 0)), nfev=int(rng.integers(100, 10**6)))
            store.write_run(row)
        store.write_adequacy(matrix_id, SCENE.name, [
            {"model": "spherical", "simpler_model": "linear", "scene_model": "linear",
             "precession_rate_diff": 7.5e-4, "trajectory_gap": 1.5e-4, "note": ""}], scene_key=scene_key(SCENE))
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


# --- a scene is its physics, not its name ------------------------------------------------------------------------


def _inline_scene(tmp_path: Path, file_name: str, latitude_deg: float):
    from foucault_bench.bench.advise import resolve_scene

    matrix_file = tmp_path / file_name
    matrix_file.write_text(f'integrators = ["rk4"]\nkh = [0.1]\n[scene.S]\nbase = "lab_3m"\nduration_s = 20.25\n'
                           f'latitude_deg = {latitude_deg}\n', encoding="utf-8")
    scene, problems = resolve_scene("S", str(matrix_file))
    assert not problems
    return matrix_file, scene


def _store_scene_rows(store: ResultsStore, scene, errors_and_costs: dict[tuple[str, float], tuple[float, float]],
                      trajectory_gap: float) -> str:
    """One matrix run holding a row per (integrator, setting) → (reference error, CPU time) of ``scene``, and its
    adequacy row (the linear model off by ``trajectory_gap``)."""
    matrix = Matrix(name="named-S", description="", source="test", scenes=(), runs=(), plugins=(),
                    timing=TimingPolicy())
    matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
    families = {"rk4": ("runge-kutta", False), "heyoka_taylor": ("taylor", True)}
    for number, ((integrator, setting), (error, cost)) in enumerate(errors_and_costs.items()):
        family, adaptive = families[integrator]
        row = dict.fromkeys(COLUMN_NAMES)
        row.update(run_key=f"{matrix_id}-{number}", matrix_id=matrix_id, scene=scene.name,
                   scene_key=scene_key(scene), model=scene.model, integrator=integrator, family=family,
                   kh=None if adaptive else setting, tol=setting if adaptive else None, duration_s=scene.duration_s,
                   n_out=scene.n_intervals + 1, status="ok", message="", reference_error=error, cpu_time_s=cost,
                   wall_time_s=cost, nfev=1000 + number)
        store.write_run(row)
    store.write_adequacy(matrix_id, scene.name, [
        {"model": scene.model, "simpler_model": "linear", "scene_model": scene.model,
         "precession_rate_diff": 1e-9, "trajectory_gap": trajectory_gap, "note": ""}], scene_key=scene_key(scene))
    store.finish_matrix_run(matrix_id)
    return matrix_id


def test_a_name_reused_with_other_physics_never_answers_for_the_original(tmp_path: Path, capsys) -> None:
    """Two matrix files define scene S at 48.8° N and 60° S; the later one's runs are cheaper and worse, and its
    adequacy row says 0.53 A. advise --matrix a.toml --scene S answers from the 48.8° N rows only: the
    recommendation is recomputed here from those rows (the cheapest meeting the target), and the model line
    quotes their 0.032 A."""
    file_a, scene_a = _inline_scene(tmp_path, "a.toml", 48.8)
    _, scene_b = _inline_scene(tmp_path, "b.toml", -60.0)
    assert scene_key(scene_a) != scene_key(scene_b)
    own = {("rk4", 0.1): (1e-7, 0.010), ("rk4", 0.05): (6e-9, 0.020), ("heyoka_taylor", 1e-9): (2e-8, 0.015)}
    other = {("rk4", 0.1): (1e-3, 0.001), ("rk4", 0.05): (7e-7, 0.002), ("heyoka_taylor", 1e-9): (2e-7, 0.003)}
    path = tmp_path / "results.sqlite"
    with ResultsStore(path) as store:
        _store_scene_rows(store, scene_a, own, trajectory_gap=0.032)
        _store_scene_rows(store, scene_b, other, trajectory_gap=0.53)  # later: the "latest" rows of the name
    target = 1e-6
    meeting = sorted((cost, integrator, setting) for (integrator, setting), (error, cost) in own.items()
                     if error <= target)
    code = cli_main(["advise", "--matrix", str(file_a), "--scene", "S", "--target", f"reference_error={target}",
                     "--db", str(path), "--json", "--no-search"])
    answer = json.loads(capsys.readouterr().out)
    assert code == 0 and answer["scene_key"] == scene_key(scene_a)
    recommended = answer["recommended"]
    assert (recommended["cost_s"], recommended["integrator"]) == meeting[0][:2]
    assert recommended["reference_error"] == own[meeting[0][1], meeting[0][2]][0]
    assert [(run["cost_s"], run["integrator"]) for run in answer["next"]] == [meeting[1][:2]]
    assert answer["stored_runs"] == len(own) and answer["runs_meeting_target"] == len(meeting)
    assert "0.032 A" in answer["model_advice"]["text"] and "0.53" not in answer["model_advice"]["text"]
    assert any(f"{len(other)} stored runs named S have other physics" in note for note in answer["notes"])


def test_advise_counts_taylor_steps_as_taylor_steps(tmp_path: Path, capsys) -> None:
    """heyoka's nfev counts Taylor steps (bench.schema): the answer says so, and says RHS evaluations for
    Runge-Kutta runs; the counts are the stored ones."""
    file_a, scene = _inline_scene(tmp_path, "a.toml", 48.8)
    path = tmp_path / "results.sqlite"
    with ResultsStore(path) as store:
        _store_scene_rows(store, scene, {("heyoka_taylor", 1e-9): (1e-9, 0.001), ("rk4", 0.05): (1e-8, 0.002)},
                          trajectory_gap=0.01)
        rows = store.frame().set_index("integrator")
    assert cli_main(["advise", "--matrix", str(file_a), "--scene", "S", "--target", "reference_error=1e-6",
                     "--db", str(path), "--no-search"]) == 0
    out = capsys.readouterr().out
    recommended = next(line for line in out.splitlines() if line.startswith("recommended:"))
    following = next(line for line in out.splitlines() if "rk4" in line)
    assert "heyoka_taylor" in recommended and f"{rows.loc['heyoka_taylor', 'nfev']} Taylor steps" in recommended
    assert "evaluations" not in recommended
    assert f"{rows.loc['rk4', 'nfev']} RHS evaluations" in following


def test_no_search_refuses_a_missing_database_and_creates_nothing(tmp_path: Path, capsys) -> None:
    missing = tmp_path / "typo" / "x.sqlite"
    assert cli_main(["advise", "--scene", "pantheon", "--target", "reference_error=1e-6", "--db", str(missing),
                     "--no-search"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no results database" in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "typo").exists()


def test_no_search_only_reads_the_database(tmp_path: Path, capsys) -> None:
    """A rollback-journal database (as another tool may write it) stays byte for byte the same, in the same
    journal mode, with no -wal file, after advise --no-search."""
    import hashlib
    import sqlite3

    path = tmp_path / "results.sqlite"
    synthetic_store(path, 0)
    with sqlite3.connect(path) as connection:
        connection.execute("PRAGMA journal_mode=DELETE")
    connection.close()
    before = hashlib.sha256(path.read_bytes()).hexdigest()
    assert cli_main(["advise", "--scene", SCENE.name, "--target", "reference_error=1e-3", "--db", str(path),
                     "--no-search"]) == 0
    capsys.readouterr()
    assert hashlib.sha256(path.read_bytes()).hexdigest() == before
    assert not (tmp_path / "results.sqlite-wal").exists()
    with sqlite3.connect(f"{path.as_uri()}?mode=ro", uri=True) as connection:
        assert connection.execute("PRAGMA journal_mode").fetchone()[0] == "delete"
    connection.close()
