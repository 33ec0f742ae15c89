"""Scenes (built-in and inline) and the reference cache; what a scene may be: its name (characters, a length
every report file name fits) and its physics (Earth's rate below the pendulum's frequency, a release that keeps
the bob below the pivot's height)."""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import time

import numpy as np
import pytest

import foucault_bench.bench.problems.reference as reference_module
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.reference import CACHE_ENVIRONMENT_VARIABLE, cache_directory, load_cached, reference_for, reference_key
from foucault_bench.bench.problems.scenes import (
    MAX_SCENE_NAME_LENGTH, MIN_OUTPUT_INTERVALS_PER_PERIOD, SCENE_DIRECTORY, SCENES, SEED_EARTH_RATE_RAD_S,
    load_scene_files, scene_from_mapping,
)
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.models import MODELS

REAL_PENDULUMS = ("pantheon", "un_headquarters", "griffith", "south_pole", "lab_3m")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_ENVIRONMENT_VARIABLE, str(tmp_path))
    return tmp_path


def problems_of(name: str, mapping: dict) -> list[str]:
    with pytest.raises(InputError) as error:
        scene_from_mapping(name, mapping)
    return error.value.problems


# --- built-in scenes --------------------------------------------------------------------------------------------


def test_the_built_in_scenes_are_the_ones_promised() -> None:
    """bench/scenes/builtin.toml holds these nine (another file of the folder may add more)."""
    north_south = {"lab_3m_ns", "quito_3m_ns"}
    builtin = load_scene_files([SCENE_DIRECTORY / "builtin.toml"])
    assert set(REAL_PENDULUMS) | {"airy_3m", "seed_2min"} | north_south == set(builtin)
    assert all(SCENES[name] == scene for name, scene in builtin.items())
    for name in north_south:  # released towards the South, on the model that has the horizontal part of ω
        assert SCENES[name].params.release_azimuth_deg == 0.0 and SCENES[name].model == "spherical"
    assert abs(SCENES["quito_3m_ns"].params.latitude_deg) < 1.0 < SCENES["lab_3m_ns"].params.latitude_deg
    assert SCENES["seed_2min"].model == "linear" and SCENES["airy_3m"].model == "spherical"
    assert SCENES["seed_2min"].params.earth_rate_rad_s == pytest.approx(2 * math.pi / 86400, rel=1e-15)
    assert SCENES["seed_2min"].params.earth_rate_rad_s == SEED_EARTH_RATE_RAD_S  # the file writes out this double
    assert SCENES["seed_2min"].duration_s == 120.0


@pytest.mark.parametrize("name", list(SCENES))
def test_each_built_in_scene_is_complete_and_its_grid_is_uniform(name: str) -> None:
    scene = SCENES[name]
    assert scene.name == name and scene.model in MODELS
    for text in (scene.title, scene.why_model, scene.source, scene.assumptions):
        assert len(text) > 20
    assert "amplitude" in scene.assumptions or "y₀" in scene.assumptions
    problem = scene.problem()
    t = problem.t_out
    assert t[0] == 0.0 and t[-1] == pytest.approx(scene.duration_s, rel=1e-12)
    assert np.allclose(np.diff(t), scene.output_interval_s, rtol=1e-12, atol=0.0)
    assert scene.output_interval_s <= scene.params.small_swing_period_s / MIN_OUTPUT_INTERVALS_PER_PERIOD
    assert problem.model is MODELS[scene.model]


@pytest.mark.parametrize("name", list(SCENES))
def test_the_swing_angles_a_scene_quotes_are_its_own(name: str) -> None:
    """The prose of a scene file is data too: every swing angle θ₀ = A/L its texts quote (to the digits quoted)
    and every Airy fraction (3/8)θ₀² (two significant digits) is the one of its length and amplitude."""
    import re

    scene = SCENES[name]
    theta0 = scene.params.amplitude_m / scene.params.length_m
    texts = " ".join((scene.why_model, scene.assumptions, scene.title))
    for quoted in re.findall(r"θ₀ [=≈] (\d+\.\d+)", texts):
        decimals = len(quoted.split(".")[1])
        assert float(quoted) == pytest.approx(theta0, abs=0.5 * 10.0**-decimals + 1e-12), (quoted, theta0)
    for quoted in re.findall(r"\(3/8\)θ₀² = (\d\.\de-\d+)", texts):
        assert quoted == f"{0.375 * theta0**2:.1e}", (quoted, theta0)


@pytest.mark.parametrize("name", REAL_PENDULUMS)
def test_real_scenes_turn_at_the_quoted_rate(name: str) -> None:
    # models/README.md "Real pendulums": degrees per hour, clockwise in the north (negative here)
    quoted = {"pantheon": -11.3, "un_headquarters": -9.8, "griffith": -8.4, "south_pole": 15.04, "lab_3m": -9.76}
    rate_deg_h = math.degrees(SCENES[name].params.textbook_precession_rate_rad_s) * 3600.0
    assert rate_deg_h == pytest.approx(quoted[name], abs=0.05)


def _toml_value(value) -> str:
    """A value as TOML writes it: independent of the reader (floats by ``repr``, which round-trips a double)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a JSON string is a TOML basic string
    return repr(float(value))


def _scene_table(scene) -> str:
    """``scene`` as a ``[scene.NAME]`` table giving every key, defaults included."""
    values = {"model": scene.model, **dataclasses.asdict(scene.params), "duration_s": scene.duration_s,
              "output_interval_s": scene.output_interval_s, "title": scene.title, "why_model": scene.why_model,
              "source": scene.source, "assumptions": scene.assumptions}
    return "\n".join([f"[scene.{scene.name}]"] + [f"{key} = {_toml_value(value)}" for key, value in values.items()])


@pytest.mark.parametrize("name", list(SCENES))
def test_every_built_in_scene_round_trips_through_toml_to_the_last_bit(name: str, tmp_path) -> None:
    """Written out as a TOML table and read back by the scene reader, each built-in scene is the same scene:
    every field equal, and the problem it poses (parameter vector, release, output grid) the same bytes."""
    scene = SCENES[name]
    path = tmp_path / "written.toml"
    path.write_text(_scene_table(scene), encoding="utf-8")
    (read,) = load_scene_files([path]).values()
    assert read == scene
    for field in dataclasses.fields(scene.params):
        assert repr(getattr(read.params, field.name)) == repr(getattr(scene.params, field.name)), field.name
    written, original = read.problem(), scene.problem()
    assert written.model is original.model
    assert written.t_out.tobytes() == original.t_out.tobytes()
    assert written.params.parameter_vector().tobytes() == original.params.parameter_vector().tobytes()
    assert written.params.initial_state().tobytes() == original.params.initial_state().tobytes()


def test_every_file_of_the_scene_folder_is_read_in_name_order_and_a_name_twice_is_an_error(tmp_path) -> None:
    """A second scene file (such as bench/scenes/real_halls.toml) adds its scenes after the first file's and may
    start from them; a name another file defines, or a key other than [scene.NAME], is refused naming the file (a [measurement.NAME] table is allowed: real halls' measured rates)."""
    (tmp_path / "builtin.toml").write_bytes((SCENE_DIRECTORY / "builtin.toml").read_bytes())
    (tmp_path / "more.toml").write_text('[scene.pantheon_2h]\nbase = "pantheon"\nduration_s = 7200.0\n',
                                        encoding="utf-8")
    scenes = load_scene_files(sorted(tmp_path.glob("*.toml")))
    assert list(scenes) == [*load_scene_files([tmp_path / "builtin.toml"]), "pantheon_2h"]
    assert scenes["pantheon_2h"].params == SCENES["pantheon"].params and scenes["pantheon_2h"].duration_s == 7200.0

    twice = tmp_path / "twice.toml"
    twice.write_text('title = "x"\n[scene.lab_3m]\nbase = "pantheon"\n', encoding="utf-8")
    with pytest.raises(InputError) as error:
        load_scene_files(sorted(tmp_path.glob("*.toml")))
    assert error.value.problems == [
        f"{twice}: unknown key 'title'; a scene file holds [scene.NAME] tables and, for real halls, "
        "[measurement.NAME] tables (their measured rates, read by the report)",
        f"{twice}: scene.lab_3m: the name 'lab_3m' is taken by a scene of builtin.toml; choose another name",
    ]


def test_a_scene_file_and_a_matrix_refuse_a_bad_scene_table_with_the_same_messages(tmp_path) -> None:
    table = ('[scene.bad]\nmodel = "lineer"\nlenght_m = 3.0\nlength_m = 3.0\nlatitude_deg = 91.0\namplitude_m = 3.0\n'
             'duration_s = 60.0\ncentrifugal = "yes"\n')
    scene_file, matrix_file = tmp_path / "scenes.toml", tmp_path / "matrix.toml"
    scene_file.write_text(table, encoding="utf-8")
    matrix_file.write_text('integrators = ["rk4"]\nkh = [0.1]\n' + table, encoding="utf-8")
    with pytest.raises(InputError) as from_scene_file:
        load_scene_files([scene_file])
    with pytest.raises(InputError) as from_matrix:
        load_matrix(matrix_file)
    about_the_scene = [message.removeprefix(f"{matrix_file}: ") for message in from_matrix.value.problems
                       if "scene.bad" in message]
    assert len(about_the_scene) == 5
    assert [message.removeprefix(f"{scene_file}: ") for message in from_scene_file.value.problems] == about_the_scene


# --- inline scenes ----------------------------------------------------------------------------------------------


def test_an_inline_scene_and_a_variant_of_a_built_in_one() -> None:
    scene = scene_from_mapping("mine", {"model": "spherical", "length_m": 10.0, "latitude_deg": -33.9,
                                        "amplitude_m": 0.5, "duration_s": 600.0, "release_velocity_m_s": [0.0, 0.01]})
    assert scene.params.release_velocity_m_s == (0.0, 0.01)
    period = scene.params.small_swing_period_s
    assert period / 8 * 0.99 < scene.output_interval_s <= period / 8  # default: about an eighth of a period
    assert scene.problem().t_out[-1] == pytest.approx(600.0, rel=1e-12)
    variant = scene_from_mapping("long_pantheon", {"base": "pantheon", "duration_s": 7200.0})
    assert variant.params == SCENES["pantheon"].params and variant.duration_s == 7200.0
    assert variant.output_interval_s == SCENES["pantheon"].output_interval_s


def test_inline_scene_problems_are_all_reported_with_suggestions() -> None:
    problems = problems_of("bad", {"model": "lineer", "lenght_m": 3.0, "length_m": 3.0, "latitude_deg": 91.0,
                                   "amplitude_m": 3.0, "duration_s": 60.0, "centrifugal": "yes"})
    assert len(problems) == 5
    joined = "\n".join(problems)
    assert "unknown key 'lenght_m' (did you mean 'length_m'?)" in joined
    assert "unknown model 'lineer' (did you mean 'linear'?)" in joined
    assert "latitude_deg must be within [-90, 90]" in joined
    assert "amplitude_m = 3.0 m must be less than length_m = 3.0 m" in joined
    assert "centrifugal must be true or false" in joined


def test_inline_scene_grid_problems() -> None:
    base = {"model": "linear", "length_m": 3.0, "latitude_deg": 45.0, "amplitude_m": 0.1}
    (coarse,) = problems_of("coarse", {**base, "duration_s": 60.0, "output_interval_s": 1.0})
    assert "too coarse" in coarse
    (uneven,) = problems_of("uneven", {**base, "duration_s": 10.1, "output_interval_s": 0.3})
    assert "not a whole number of output intervals" in uneven and "9.9 or 10.2" in uneven
    missing = problems_of("missing", {"model": "linear"})
    assert len(missing) == 1 and "length_m, latitude_deg, amplitude_m, duration_s" in missing[0]
    typed = problems_of("typed", {**base, "duration_s": "an hour", "release_velocity_m_s": [1.0]})
    assert len(typed) == 2
    assert problems_of("based", {"base": "panteon"}) == [
        "base: unknown scene 'panteon' (did you mean 'pantheon'?); built-in scenes: " + ", ".join(SCENES)]


# --- names and physical limits ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["lab\n", "lab\r", "\nlab", "lab name", "lab/x", ""])
def test_scene_names_of_other_characters_are_refused(name: str) -> None:
    """A final newline passed ``match`` with ``$``: the whole name must match."""
    (problem,) = problems_of(name, {"base": "seed_2min"})
    assert problem.startswith("scene name ") and "may hold only" in problem


@pytest.mark.parametrize("name", ["l" * (MAX_SCENE_NAME_LENGTH + 1), "L" * 130, "x" * 250])
def test_scene_names_too_long_for_a_report_are_refused_in_a_matrix(name: str) -> None:
    """250 characters (or 130 capitals, 260 after file_stem's escaping) passed and made the report fail with
    "File name too long". The limit is the matrix's: scenes made inside a computation may be longer."""
    from foucault_bench.bench.run.matrix import parse_matrix

    with pytest.raises(InputError) as error:
        parse_matrix({"scene": {name: {"base": "seed_2min"}}, "integrators": ["rk4"], "kh": [0.2]}, source="m")
    (problem,) = error.value.problems
    assert f"has {len(name)} characters, more than {MAX_SCENE_NAME_LENGTH}" in problem
    assert scene_from_mapping(name, {"base": "seed_2min"}).name == name


def test_a_report_for_the_longest_scene_name_writes_every_file_within_255_bytes(tmp_path, monkeypatch) -> None:
    """The worst case end to end: a name of MAX_SCENE_NAME_LENGTH capitals (file_stem doubles each) through
    the report itself, with every chart that carries a scene name (work-precision for each verdict,
    convergence, tolerance). Every file it writes has a name of at most 255 bytes, the stem really is in the
    derived names, and the longest leaves room (≥ 32 bytes) for a temporary file's decoration. The charts are
    written by the report's own ``charts.save`` with an empty figure in place of the drawn one (drawing them
    takes a minute on a loaded machine and changes no file name)."""
    import pandas as pd
    from matplotlib.figure import Figure

    import foucault_bench.reports.charts as charts
    from foucault_bench.reports.build import ReportInputs, build_report, file_stem
    from test_reports import results_fixture

    real_save = charts.save
    monkeypatch.setattr(charts, "save", lambda figure, stem: real_save(Figure(figsize=(1, 1)), stem))
    longest = "L" * MAX_SCENE_NAME_LENGTH
    scene_from_mapping(longest, {"base": "seed_2min"})  # accepted
    runs = results_fixture()
    runs = runs[(runs["scene"] == "lab") & runs["integrator"].isin(["rk4", "heyoka_taylor"])].copy()
    runs["scene"] = longest
    build_report(ReportInputs(runs=pd.DataFrame(runs), interactive=False), tmp_path)
    names = [path.name for path in tmp_path.rglob("*")]
    stem = file_stem(longest)
    assert len(stem) == 2 * MAX_SCENE_NAME_LENGTH
    derived = [name for name in names if stem in name]
    assert {name.split(stem)[0] for name in derived} >= {"work_precision_", "convergence_", "tolerance_"}
    assert max(len(name.encode()) for name in names) <= 255 - 32, max(names, key=len)


def _jacobi_margin_speed(params) -> float:
    """The largest release speed along the scene's velocity direction that keeps the spherical model's Jacobi
    integral h = ½|ṙ|² + g z − ½|ω×r|² below −½|ω|²L² (its least value at the pivot's height), computed here
    from the vectors (numpy cross products), independently of bench.problems.scenes."""
    length, g = params.length_m, params.gravity_m_s2
    psi = math.radians(params.release_azimuth_deg)
    x, y = params.amplitude_m * math.cos(psi), params.amplitude_m * math.sin(psi)
    z = -math.sqrt(length**2 - x**2 - y**2)
    direction = np.array(params.release_velocity_m_s) / math.hypot(*params.release_velocity_m_s)
    unit_velocity = np.array([direction[0], direction[1], -(x * direction[0] + y * direction[1]) / z])
    omega = np.array(params.omega_vector_rad_s)
    at_rest = g * z - 0.5 * np.sum(np.cross(omega, [x, y, z]) ** 2) + 0.5 * np.sum(omega**2) * length**2
    return math.sqrt(-2.0 * at_rest / np.sum(unit_velocity**2))


@pytest.mark.parametrize(("base", "direction"), [("seed_2min", (1.0, 0.0)), ("lab_3m", (0.0, 1.0)),
                                                   ("airy_3m", (0.6, -0.8))])
def test_a_release_speed_that_lifts_the_bob_to_the_pivot_is_refused_at_the_right_speed(base, direction) -> None:
    """Accepted just below the speed that lifts the bob to the pivot's height (recomputed here), refused just
    above it and at 1e300 m/s (accepted before), with the limit in the message."""
    probe = dataclasses.replace(SCENES[base].params, release_velocity_m_s=direction)
    limit = _jacobi_margin_speed(probe)
    below = scene_from_mapping("fast", {"base": base, "release_velocity_m_s": [0.999 * limit * c for c in direction]})
    assert math.hypot(*below.params.release_velocity_m_s) < limit
    for speed in (1.001 * limit, 1e300):
        (problem,) = problems_of("fast", {"base": base, "release_velocity_m_s": [speed * c for c in direction]})
        assert "release_velocity_m_s" in problem and "pivot's height" in problem
        assert float(problem.split("must stay below ")[1].split(" m/s")[0]) == pytest.approx(limit, rel=1e-5)


def test_a_release_from_rest_that_the_centrifugal_force_could_lift_to_the_pivot_is_refused() -> None:
    """At the equator ω is horizontal (along −x); a bob released from rest near the axis (azimuth 0°) at
    A = 0.99 L with Ω = 0.96 k has the Jacobi integral h₀ = g z₀ − ½|ω×r₀|² above −½Ω²L², the value level with
    the pivot across the axis (y = ±L): the centrifugal force can lift it there. Released across the axis
    (azimuth 90°) it cannot. Both numbers are computed here."""
    k = math.sqrt(9.81 / 1.0)
    fields = {"model": "spherical", "length_m": 1.0, "latitude_deg": 0.0, "amplitude_m": 0.99, "duration_s": 10.0,
              "earth_rate_rad_s": 0.96 * k}
    z0 = -math.sqrt(1.0 - 0.99**2)
    omega = 0.96 * k
    along_axis = 9.81 * z0 - 0.5 * omega**2 * z0**2  # r₀ = (A, 0, z₀): |ω×r₀|² = Ω² z₀²
    across_axis = 9.81 * z0 - 0.5 * omega**2 * (0.99**2 + z0**2)  # r₀ = (0, A, z₀)
    assert along_axis > -0.5 * omega**2 > across_axis
    (problem,) = problems_of("lifted", {**fields, "release_azimuth_deg": 0.0})
    assert "even from rest" in problem
    assert scene_from_mapping("held", {**fields, "release_azimuth_deg": 90.0}).params.amplitude_m == 0.99


def test_earths_rate_must_stay_below_the_pendulums_frequency() -> None:
    """Ω ≥ k = √(g/L) is refused (1e10 rad/s was accepted), naming k; just below it is a valid scene."""
    k = SCENES["seed_2min"].params.pendulum_frequency_rad_s
    for rate in (1e10, k):
        (problem,) = problems_of("spun", {"base": "seed_2min", "earth_rate_rad_s": rate})
        assert "earth_rate_rad_s" in problem and f"{k:.6g} rad/s" in problem
    assert scene_from_mapping("spun", {"base": "seed_2min", "earth_rate_rad_s": 0.9 * k}).params.earth_rate_rad_s


# --- the reference cache ----------------------------------------------------------------------------------------


def short_linear_scene(**changes):
    return dataclasses.replace(SCENES["seed_2min"], **{"name": "cache_test", "duration_s": 60.0, **changes})


def test_reference_cache_hit_is_bit_identical_and_a_changed_scene_misses(cache) -> None:
    scene = short_linear_scene()
    assert load_cached(scene) is None
    computed = reference_for(scene)
    stored = sorted(path.name for path in cache_directory().iterdir())
    assert stored == [f"{computed.key}.lock", f"{computed.key}.npz"]  # no temporary file left behind
    loaded = load_cached(scene)
    assert loaded.t.tobytes() == computed.t.tobytes() and loaded.y.tobytes() == computed.y.tobytes()
    assert loaded.turning_points.tobytes() == computed.turning_points.tobytes()
    assert loaded.precession_rate_rad_s == computed.precession_rate_rad_s
    assert reference_for(scene) is computed  # kept in memory within the process
    # the name and texts do not change the physics; any physical field does
    renamed = dataclasses.replace(scene, name="other_name", title="another title")
    assert reference_key(renamed) == computed.key
    changed = short_linear_scene(params=dataclasses.replace(scene.params, amplitude_m=0.4))
    assert reference_key(changed) != computed.key and load_cached(changed) is None
    longer = dataclasses.replace(scene, duration_s=62.0)
    assert reference_key(longer) != computed.key and load_cached(longer) is None


def test_concurrent_requests_compute_a_reference_once(cache, monkeypatch) -> None:
    scene = short_linear_scene(duration_s=40.0)
    calls = []
    original = reference_module._compute

    def slow_compute(*args, **kwargs):
        calls.append(1)
        time.sleep(0.3)  # widen the window in which the other thread would compute too
        return original(*args, **kwargs)

    monkeypatch.setattr(reference_module, "_compute", slow_compute)
    results = []
    threads = [threading.Thread(target=lambda: results.append(reference_for(scene))) for _ in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(calls) == 1 and len(results) == 3
    assert all(result.y.tobytes() == results[0].y.tobytes() for result in results)


def test_a_reference_that_cannot_finish_is_an_error_and_is_not_cached(cache, monkeypatch) -> None:
    from foucault_bench.integrators import Solution
    from foucault_bench.integrators.methods.heyoka_taylor import HeyokaTaylorQuad

    def failing(self, problem, **kwargs):
        return Solution.failure(problem.t_out, "step limit reached")

    monkeypatch.setattr(HeyokaTaylorQuad, "solve", failing)
    scene = short_linear_scene(duration_s=30.0)
    with pytest.raises(RuntimeError, match="step limit reached"):
        reference_for(scene)
    assert load_cached(scene) is None
