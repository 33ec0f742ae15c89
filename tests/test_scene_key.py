"""Scene keys: a scene is its physics, not its name. The key is canonical (equal physics, equal key; any change
of the physics, another key), rows carry it, and the report shows one name with two physics as two scenes."""

from __future__ import annotations

import dataclasses
import hashlib
import json

import pandas as pd

from foucault_bench.bench.problems.scene_key import SCENE_KEY_HEX_DIGITS, scene_key, scene_labels
from foucault_bench.bench.problems.scenes import SCENES, scene_from_mapping
from foucault_bench.bench.run.matrix import parse_matrix
from foucault_bench.bench.run.execute import base_row
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.run.summary import summarize
from foucault_bench.bench.schema import COLUMNS

SCENE = SCENES["lab_3m"]


def test_the_key_is_a_hash_of_the_physics_written_canonically() -> None:
    """Recomputed here from the definition: SHA-256 of the sorted, compact JSON of model, parameters, duration
    and output interval, every number as float.hex; a refining model's parameter (support anisotropy, drag,
    drive) at its default is left out, so that adding such a field kept the keys of the scenes stored before."""
    refinements = {field.name: field.default for field in dataclasses.fields(SCENE.params)
                   if field.metadata.get("refinement")}
    assert refinements  # the real-pendulum fields (support anisotropy, drag, drive) and any added later
    params = {name: (value if isinstance(value, bool) else [float(v).hex() for v in value]
                     if isinstance(value, tuple) else float(value).hex())
              for name, value in dataclasses.asdict(SCENE.params).items()
              if name not in refinements or value != refinements[name]}
    physics = {"model": SCENE.model, "params": params, "duration_s": float(SCENE.duration_s).hex(),
               "output_interval_s": float(SCENE.output_interval_s).hex()}
    text = json.dumps(physics, sort_keys=True, separators=(",", ":"))
    assert scene_key(SCENE) == hashlib.sha256(text.encode()).hexdigest()[:SCENE_KEY_HEX_DIGITS]


def test_equal_physics_gives_one_key_and_any_change_another() -> None:
    as_integers = scene_from_mapping("other_name", {"base": "lab_3m", "length_m": 3, "duration_s": 1800})
    assert scene_key(as_integers) == scene_key(SCENE)  # name, texts, 3 versus 3.0: the same physics
    changes = {"model": "linear", "duration_s": 900.0, "output_interval_s": 0.5}
    parameter_changes = {"length_m": 3.0000000000000004, "latitude_deg": -40.44, "amplitude_m": 0.1,
                         "gravity_m_s2": 9.80665, "earth_rate_rad_s": 0.0, "release_azimuth_deg": 0.0,
                         "release_velocity_m_s": (0.0, 0.01), "centrifugal": False, "support_anisotropy": 1e-5,
                         "anisotropy_axis_deg": 30.0, "drag_linear_per_s": 1e-4, "drag_quadratic_per_m": 1e-3,
                         "drive_gain_per_s": 1e-3, "drive_radius_m": 0.2}
    variants = [dataclasses.replace(SCENE, **{field: value}) for field, value in changes.items()]
    variants += [dataclasses.replace(SCENE, params=dataclasses.replace(SCENE.params, **{field: value}))
                 for field, value in parameter_changes.items()]
    keys = {scene_key(variant) for variant in variants}
    assert len(keys) == len(variants) and scene_key(SCENE) not in keys


def test_every_row_carries_its_scenes_key() -> None:
    matrix = parse_matrix({"integrators": ["rk4"], "kh": [0.1], "scene": {"S": {"base": "lab_3m", "duration_s": 9.0}}},
                          source="test", default_name="keys")
    for spec in matrix.runs:
        assert base_row(spec, "m")["scene_key"] == scene_key(spec.scene)


def test_labels_name_a_scene_plainly_unless_its_name_has_several_physics() -> None:
    rows = pd.DataFrame({"scene": ["a", "a", "b", "a", "c"],
                         "scene_key": ["123456789abc", "123456fff000", "77", None, None]})
    assert scene_labels(rows).tolist() == ["a [1234567]", "a [123456f]", "b", "a [unknown physics]", "c"]
    assert scene_labels(rows.iloc[[0, 2]]).tolist() == ["a", "b"]
    assert scene_labels(rows.iloc[[0, 2]], among=rows).tolist() == ["a [1234567]", "b"]


def _rows_of_two_physics(store: ResultsStore) -> tuple[str, dict[str, str]]:
    """One matrix run whose scene S has two physics (two latitudes), rk4 and cvode_bdf on each; returns the
    matrix id and key → latitude text."""
    from test_store import fake_row

    matrices = [parse_matrix({"integrators": ["rk4", "cvode_bdf"], "kh": [0.2], "tol": [1e-6],
                              "scene": {"S": {"base": "lab_3m", "duration_s": 9.0, "latitude_deg": latitude}}},
                             source="test", default_name="two") for latitude in (40.0, -60.0)]
    matrix_id, _ = store.start_matrix_run(matrices[0], jobs=1, scheduler=None, resume=False)
    keys = {}
    for number, matrix in enumerate(matrices):
        for index, run in enumerate(matrix.runs):
            row = fake_row(run, matrix_id, 2 * number + index)
            row.update({column.name: 1e-6 * (1 + index) for column in COLUMNS  # every number present
                        if column.sql_type == "REAL" and row[column.name] is None
                        and column.name not in ("kh", "step_s", "tol", "stability_limit_kh")})
            row.update(reference_error=1e-7 * (1 + index), cpu_time_s=0.01 * (1 + index))
            store.write_run(row)
            keys[scene_key(run.scene)] = str(run.scene.params.latitude_deg)
    store.finish_matrix_run(matrix_id)
    return matrix_id, keys


def test_the_summary_has_a_line_per_physics_of_a_name(tmp_path) -> None:
    with ResultsStore(tmp_path / "db.sqlite") as store:
        _, keys = _rows_of_two_physics(store)
        lines = summarize(store.records())
    assert sorted((line["scene"], line["integrator"], line["runs"]) for line in lines) == sorted(
        (f"S [{key[:6]}]", integrator, 1) for key in keys for integrator in ("rk4", "cvode_bdf"))


def test_the_report_groups_a_name_with_two_physics_as_two_scenes(tmp_path, monkeypatch) -> None:
    """What ``write_report`` hands to the report builder (which groups by ``scene``): each run labelled with its
    own physics, recomputed here from the stored keys, and the adequacy rows likewise. (The builder is replaced by
    one that records its inputs: drawing the charts is the report's own tests' business.)"""
    from foucault_bench.reports import build

    database = tmp_path / "db.sqlite"
    with ResultsStore(database) as store:
        matrix_id, keys = _rows_of_two_physics(store)
        for key in keys:
            store.write_adequacy(matrix_id, "S", [{"model": "spherical", "simpler_model": "linear",
                                                   "trajectory_gap": float(keys[key])}], scene_key=key)
        rows = store.frame()
    handed = {}

    def record(inputs, folder, **options):
        handed["inputs"] = inputs
        return folder / "index.html", folder / "REPORT.md"

    monkeypatch.setattr(build, "build_report", record)
    assert build.write_report(database, None, tmp_path / "report", studies="skip") == 0
    runs, adequacy = handed["inputs"].runs, handed["inputs"].adequacy
    expected = {key: f"S [{key[:6]}]" for key in keys}
    assert list(runs["scene"]) == [expected[key] for key in rows["scene_key"]]
    groups = {label: set(group["run_key"]) for label, group in runs.groupby("scene")}
    assert groups == {expected[key]: set(rows.loc[rows["scene_key"] == key, "run_key"]) for key in keys}
    assert {label: gap for label, gap in zip(adequacy["scene"], adequacy["trajectory_gap"], strict=True)} == {
        expected[key]: float(latitude) for key, latitude in keys.items()}

