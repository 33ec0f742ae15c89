"""Matrix files: every validation error is refused before anything runs (exit 2, one clear message per
problem, no traceback), and valid files expand into the runs they describe."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.run.matrix import built_in_matrices, load_matrix, parse_matrix
from foucault_bench.bench.problems.reference import REFERENCE_INTEGRATOR
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.integrators import REGISTRY, built_in_names

VALID = """
scenes = ["seed_2min"]
integrators = ["rk4", "cvode_bdf"]
kh = [0.2, 0.1]
tol = [1e-6]
"""


def write(tmp_path: Path, text: str, name: str = "matrix.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


def run_cli(tmp_path: Path, matrix: str, capsys) -> tuple[int, str]:
    """``foucault-bench run`` on ``matrix``; returns (exit status, stderr). The database must stay untouched."""
    database = tmp_path / "never.sqlite"
    status = cli_main(["run", "--matrix", matrix, "--db", str(database), "--no-progress"])
    captured = capsys.readouterr()
    assert not database.exists(), "an invalid matrix must be refused before anything is stored"
    return status, captured.err


# One case per validation rule: (matrix text, substrings the one message about it must contain).
CASES = {
    "unknown scene": ('scenes = ["pantheonn"]\nintegrators = ["rk4"]\nkh = [0.1]',
                      ["unknown scene 'pantheonn'", "did you mean 'pantheon'"]),
    "unknown integrator": ('scenes = ["seed_2min"]\nintegrators = ["rk5"]\nkh = [0.1]',
                           ["unknown integrator 'rk5'", "did you mean 'rk4'"]),
    "step size zero": ('scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [0.0]', ["step size must be > 0", "kh = 0.0"]),
    "step size negative": ('scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [-0.1]', ["step size must be > 0"]),
    "step too coarse for the grid": ('scenes = ["pantheon"]\nintegrators = ["rk4"]\nkh = [2.0]',
                                     ["kh = 2 exceeds", "'pantheon'"]),
    "tolerance one": ('scenes = ["seed_2min"]\nintegrators = ["cvode_bdf"]\ntol = [1.0]', ["tolerance must lie in (0, 1)"]),
    "tolerance zero": ('scenes = ["seed_2min"]\nintegrators = ["cvode_bdf"]\ntol = [0.0]', ["tolerance must lie in (0, 1)"]),
    "latitude": ('integrators = ["rk4"]\nkh = [0.1]\n[scene.far_north]\nbase = "seed_2min"\nlatitude_deg = 95.0',
                 ["scene.far_north", "latitude_deg", "95"]),
    "amplitude not below length": (
        'integrators = ["rk4"]\nkh = [0.1]\n[scene.long_swing]\nbase = "lab_3m"\namplitude_m = 3.0',
        ["scene.long_swing", "amplitude_m", "less than length_m"]),
    "unknown top-level key": ('scenes = ["seed_2min"]\nintegrator = ["rk4"]\nkh = [0.1]',
                              ["unknown key 'integrator'", "did you mean 'integrators'"]),
    "unknown scene key": ('integrators = ["rk4"]\nkh = [0.1]\n[scene.lab]\nbase = "lab_3m"\nlenght_m = 2.0',
                          ["scene.lab", "unknown key 'lenght_m'", "did you mean 'length_m'"]),
    "unknown timing key": ('scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [0.1]\n[timing]\nmin_repeat = 2',
                           ["unknown key 'min_repeat'", "did you mean 'min_repeats'"]),
    "tolerance for a fixed-step integrator": (
        'scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [0.1]\n[override.rk4]\ntol = [1e-6]',
        ["override.rk4", "fixed-step", "tol does not apply"]),
    "step size for an adaptive integrator": (
        'scenes = ["seed_2min"]\nintegrators = ["cvode_bdf"]\ntol = [1e-6]\n[override.cvode_bdf]\nkh = [0.1]',
        ["override.cvode_bdf", "adaptive", "kh does not apply"]),
    "shared tolerance unused": ('scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [0.1]\ntol = [1e-6]',
                                ["tol is given but no listed adaptive integrator uses it"]),
    "no sweep for an integrator": ('scenes = ["seed_2min"]\nintegrators = ["cvode_bdf"]',
                                   ["cvode_bdf is adaptive", "no tol sweep"]),
    "reference integrator": ('scenes = ["seed_2min"]\nintegrators = ["heyoka_taylor_quad"]\ntol = [1e-6]',
                             ["heyoka_taylor_quad computes the references"]),
    "unknown integrators form": ('scenes = ["seed_2min"]\nintegrators = "builtin"\nkh = [0.1]',
                                 ["integrators: unknown form 'builtin'", "did you mean 'built-in'"]),
    "step_energy not a boolean": ('scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [0.1]\nstep_energy = "no"',
                                  ["step_energy must be true or false", "'no'"]),
    "unreadable TOML": ('scenes = ["seed_2min"]\nintegrators = ["rk4"\nkh = [0.1]', ["not valid TOML", "line 3"]),
    "unimportable plug-in": ('plugins = ["no_such_module_here"]\nscenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [0.1]',
                             ["plugins: cannot import 'no_such_module_here'"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_each_invalid_matrix_is_refused_with_a_message_naming_the_problem(case, tmp_path, capsys):
    text, expected = CASES[case]
    status, err = run_cli(tmp_path, str(write(tmp_path, text)), capsys)
    assert status == 2
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("foucault-bench run: error:")]
    assert any(all(piece in line for piece in expected) for line in lines), err


def test_every_problem_of_a_file_is_reported_at_once(tmp_path, capsys):
    text = """
    scenes = ["pantheonn", "seed_2min"]
    integrators = ["rk5", "rk4", "cvode_bdf"]
    kh = [0.1, -1.0]
    tol = [2.0]
    colour = "red"
    [override.rk4]
    tol = [1e-6]
    [scene.south]
    base = "seed_2min"
    latitude_deg = -91.0
    """
    status, err = run_cli(tmp_path, str(write(tmp_path, text)), capsys)
    assert status == 2 and "Traceback" not in err
    for piece in ("'pantheonn'", "'rk5'", "kh = -1.0", "tol = 2.0", "'colour'", "override.rk4", "latitude_deg"):
        assert sum(piece in line for line in err.splitlines()) == 1, (piece, err)


def test_missing_file_and_unknown_built_in_are_refused_with_a_suggestion(tmp_path, capsys):
    status, err = run_cli(tmp_path, "quik", capsys)
    assert status == 2 and "did you mean 'quick'" in err and "Traceback" not in err
    status, err = run_cli(tmp_path, str(tmp_path / "absent.toml"), capsys)
    assert status == 2 and "absent.toml" in err


def test_a_valid_matrix_expands_into_every_scene_integrator_setting(tmp_path):
    text = VALID.replace("kh = [0.2, 0.1]", "") + (
        '[scene.lab_short]\nbase = "lab_3m"\nduration_s = 90.0\n[override.rk4]\nkh = [0.3, 0.15, 0.075]\n')
    matrix = load_matrix(write(tmp_path, text))
    assert matrix.name == "matrix"  # the file's stem
    assert [scene.name for scene in matrix.scenes] == ["seed_2min", "lab_short"]
    runs = {(run.scene.name, run.integrator, run.setting) for run in matrix.runs}
    assert len(runs) == len(matrix.runs) == 2 * (3 + 1)
    assert ("lab_short", "rk4", "kh=0.075") in runs and ("seed_2min", "cvode_bdf", "tol=1e-06") in runs
    for run in matrix.runs:
        if run.kh is not None:
            assert run.tol is None
            assert run.step_s == pytest.approx(run.kh / run.scene.params.pendulum_frequency_rad_s, rel=1e-15)
        else:
            assert run.step_s is None and run.tol == 1e-6
    assert len({run.run_key for run in matrix.runs}) == len(matrix.runs)


def test_run_keys_depend_on_scene_physics_setting_and_nothing_else(tmp_path):
    base = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.1]})
    again = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.1], "description": "other"})
    other_step = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.05]})
    other_physics = parse_matrix({"integrators": ["rk4"], "kh": [0.1],
                                  "scene": {"seed_2min_x": {"base": "seed_2min", "amplitude_m": 0.4}}})
    key = base.runs[0].run_key
    assert again.runs[0].run_key == key and again.matrix_hash == base.matrix_hash
    assert other_step.runs[0].run_key != key
    assert other_physics.runs[0].run_key != key


def test_built_in_matrices_load_and_cover_every_built_in_family():
    """Only built-in integrators are held to this: an installed plug-in of a new family is not in the
    project's matrices and must not fail the project's tests."""
    assert {"default", "quick"} <= set(built_in_matrices())
    families_swept = set()
    for name in ("default", "quick"):
        matrix = load_matrix(name)
        families_swept |= {REGISTRY[run.integrator].family for run in matrix.runs}
        assert all(run.integrator != REFERENCE_INTEGRATOR for run in matrix.runs)
    built_in_families = {REGISTRY[name].family for name in built_in_names() if name != REFERENCE_INTEGRATOR}
    assert built_in_families <= families_swept
    default = load_matrix("default")
    from foucault_bench.bench.problems.scenes import SCENE_DIRECTORY, load_scene_files

    # the default matrix sweeps exactly the scenes of builtin.toml; every other built-in scene (real_halls.toml,
    # a new scenes file) is swept by some built-in matrix (bench/README.md "Scenes")
    builtin = load_scene_files([SCENE_DIRECTORY / "builtin.toml"])
    assert {scene.name for scene in default.scenes} == set(builtin)
    swept = {scene.name for name in built_in_matrices() for scene in load_matrix(name).scenes}
    unswept = sorted(set(SCENES) - swept)
    assert not unswept, f"built-in scenes no built-in matrix sweeps: {unswept} (list each under scenes = [...] " \
                        "in the built-in matrix that should run it)"
    tolerances = sorted({run.tol for run in default.runs if run.tol is not None})
    assert tolerances[0] <= 1e-13 and tolerances[-1] >= 1e-4


def test_built_in_integrators_are_every_built_in_but_the_reference_as_if_listed(tmp_path):
    """``integrators = "built-in"`` (the built-in matrices' form) is the registry's built-ins without the reference
    integrator, and the same runs, run keys, order and matrix hash as the explicit list of those names, with
    ``[override.NAME]`` tables applied to the expansion."""
    text = 'scenes = ["seed_2min"]\nintegrators = "built-in"\nkh = [0.2]\ntol = [1e-6]\n[override.rk4]\nkh = [0.1]\n'
    expanded = load_matrix(write(tmp_path, text, "built_in.toml"))
    names = [name for name in built_in_names() if name != REFERENCE_INTEGRATOR]
    listed = load_matrix(write(tmp_path, text.replace('"built-in"', repr(names).replace("'", '"')), "built_in.toml"))
    assert list(dict.fromkeys(run.integrator for run in expanded.runs)) == names
    assert [run.run_key for run in expanded.runs] == [run.run_key for run in listed.runs]
    assert expanded.matrix_hash == listed.matrix_hash
    assert {run.setting for run in expanded.runs if run.integrator == "rk4"} == {"kh=0.1"}


# --- generated scene names ------------------------------------------------------------------------------------


def test_azimuth_variants_have_distinct_names_that_read_back_as_their_azimuths():
    """45 and 45.0000001 both formatted as ``45`` with ``:g``: two scenes named seed_2min-az45, merged by the
    report. The label is the float's shortest round-trip text, so each name reads back as its azimuth."""
    azimuths = [45, 45.0000001, 0.1 + 0.2, 1e20, -1e-05, 359.99999999999994]
    matrix = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.2],
                           "release_azimuth_deg": azimuths})
    names = [scene.name for scene in matrix.scenes]
    assert len(set(names)) == len(azimuths)
    assert names[:2] == ["seed_2min-az45", "seed_2min-az45.0000001"]
    for scene, azimuth in zip(matrix.scenes, azimuths, strict=True):
        assert float(scene.name.removeprefix("seed_2min-az")) == azimuth == scene.params.release_azimuth_deg


def test_two_scenes_of_one_name_are_refused(monkeypatch):
    """The guard behind the labels: with the old ``:g`` label the collision is one line, exit 2, not two
    scenes merged."""
    import foucault_bench.bench.run.matrix_scenes as matrix_module

    monkeypatch.setattr(matrix_module, "azimuth_label", lambda azimuth: f"{azimuth:g}")
    with pytest.raises(InputError) as caught:
        parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.2],
                      "release_azimuth_deg": [45, 45.0000001]}, source="m")
    assert caught.value.problems == [
        "m: 2 scenes are named 'seed_2min-az45' (rows and report files are keyed by the scene name): rename the "
        "inline scene or change the azimuth"]


def test_a_variant_name_past_the_length_limit_is_one_line_naming_the_azimuth():
    from foucault_bench.bench.problems.scenes import MAX_SCENE_NAME_LENGTH

    name = "s" * (MAX_SCENE_NAME_LENGTH - 4)
    with pytest.raises(InputError) as caught:
        parse_matrix({"scene": {name: {"base": "seed_2min"}}, "integrators": ["rk4"], "kh": [0.2],
                      "release_azimuth_deg": [5, 0.125]}, source="m")
    (problem,) = caught.value.problems
    assert problem.startswith(f"m: scene name '{name}-az0.125' has {MAX_SCENE_NAME_LENGTH + 4} characters, more than ")


def test_a_variant_whose_release_lifts_the_bob_to_the_pivot_is_refused_naming_its_azimuth():
    """The speed limit depends on the release direction: a sideways push just below it (azimuth 90° with
    velocity along x) becomes a push along the string's swing (azimuth 0°), refused for that variant only."""
    from foucault_bench.bench.problems.scenes import SCENES

    params = SCENES["lab_3m"].params  # released at azimuth 90°: x is sideways
    sideways_limit = (2 * params.gravity_m_s2 * (params.length_m**2 - params.amplitude_m**2) ** 0.5) ** 0.5
    with pytest.raises(InputError) as caught:
        parse_matrix({"scene": {"lab": {"base": "lab_3m", "release_velocity_m_s": [0.9995 * sideways_limit, 0.0]}},
                      "integrators": ["rk4"], "kh": [0.2], "release_azimuth_deg": [90, 0]}, source="m")
    (problem,) = caught.value.problems
    assert problem.startswith("m: release_azimuth_deg = 0 of scene 'lab': release_velocity_m_s = ")


def test_only_the_main_job_leaves_out_the_per_step_energy_error():
    """The `default` matrix says ``step_energy = false`` (its report does not draw that column, bench/PERF.md
    "The per-step energy error made optional"), and so do all its runs; the other built-in matrices keep the
    default, true."""
    for name in built_in_matrices():
        matrix = load_matrix(name)
        assert matrix.step_energy == (name != "default"), name
        assert {run.step_energy for run in matrix.runs} == {matrix.step_energy}, name
