"""Tests of the CI gate ``foucault-bench check`` (bench/gate/) and its shipped thresholds.

What they prove:

* the shipped ``default`` thresholds hold on a fresh run of the ``quick`` matrix (exit 0), and the JUnit report
  carries one test case per checked line;
* the gate can fail: two wrong integrators (``tests/check_mutants.py``: RK4 with a wrong weight, Verlet with the
  naive explicit Coriolis kick), held to the shipped bounds of the integrators they imitate, make ``check`` exit 1
  and name the violated bounds;
* bad input (unknown integrator, scene or column, malformed TOML, a bound that selects no row, a wall-time bound
  that is not a ratio) exits 2 with a clear message before any matrix runs;
* the evaluation rules (ratio bounds, runs that are not ok, margins) on small hand-made tables.

One matrix run serves the module (the quick matrix with the mutants added, through the real runner and its
worker processes; the mutants reach the workers as a matrix plug-in). Nothing here measures or bounds
wall-clock time: the ratio test uses made-up numbers.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import sys
import tomllib
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pandas as pd
import pytest

from foucault_bench.bench.gate.evaluate import evaluate, headroom
from foucault_bench.bench.gate.render import render
from foucault_bench.bench.gate.select import validate_against
from foucault_bench.bench.gate.thresholds import ERROR_COLUMNS, load_thresholds, parse_thresholds
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.bench.cli import main
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.schema import COLUMN_NAMES
from foucault_bench.integrators import REGISTRY, unregister

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent
QUICK_MATRIX = ROOT / "bench" / "matrices" / "quick.toml"
DEFAULT_THRESHOLDS = ROOT / "bench" / "thresholds" / "default.toml"
MUTANT_PLUGIN = "check_mutants"
MUTANT_OF = {"rk4": "rk4_wrong_weights", "verlet": "verlet_naive_coriolis"}
JOBS = "2"


def run_cli(argv: list[str]) -> tuple[int, str]:
    """``foucault-bench ARGV`` in this process: (exit status, stdout)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main(argv)
    return status, out.getvalue()


def write_toml_lines(path: Path, lines: list[str]) -> Path:
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def toml_value(value) -> str:
    """A TOML literal for the plain values used in these files (str, number, bool, list of those)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(item) for item in value) + "]"
    return repr(value)


def junit_cases(path: Path) -> list[ElementTree.Element]:
    return list(ElementTree.parse(path).getroot().iter("testcase"))


# --- one matrix run: the quick matrix plus two wrong integrators ----------------------------------------------------


def toml_text(document: dict) -> str:
    """A matrix or thresholds document as TOML: top-level values, then tables ([timing]), tables of tables
    ([scene.NAME]) and arrays of tables ([[bound]]); enough for the files used here."""
    lines = [f"{key} = {toml_value(value)}" for key, value in document.items()
             if not isinstance(value, dict) and not (isinstance(value, list) and value and isinstance(value[0], dict))]
    for key, value in document.items():
        if isinstance(value, dict) and all(isinstance(inner, dict) for inner in value.values()):
            for name, table in value.items():
                lines += [f"[{key}.{name}]"] + [f"{field} = {toml_value(item)}" for field, item in table.items()]
        elif isinstance(value, dict):
            lines += [f"[{key}]"] + [f"{field} = {toml_value(item)}" for field, item in value.items()]
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            for table in value:
                lines += [f"[[{key}]]"] + [f"{field} = {toml_value(item)}" for field, item in table.items()]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def gate_run(tmp_path_factory) -> dict:
    """``check --thresholds default`` on one fresh matrix run: the quick matrix with the two mutants of
    tests/check_mutants.py added on the same scenes and steps (the quick integrators' rows are those of the quick
    matrix; the shipped bounds do not select the mutants). The mutants reach the spawned workers as a matrix
    plug-in (the workers inherit sys.path) and leave the registry when the module's tests are done."""
    directory = tmp_path_factory.mktemp("gate")
    quick = tomllib.loads(QUICK_MATRIX.read_text(encoding="utf-8"))
    quick_integrators = list(dict.fromkeys(run.integrator for run in load_matrix("quick").runs))  # "built-in"
    matrix = {**quick, "name": "quick_and_mutants", "integrators": [*quick_integrators, *MUTANT_OF.values()],
              "plugins": [*quick.get("plugins", []), MUTANT_PLUGIN]}
    matrix_path = directory / "quick_and_mutants.toml"
    matrix_path.write_text(toml_text(matrix), encoding="utf-8")
    db, junit = directory / "gate.sqlite", directory / "junit.xml"
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(TESTS))
        status, stdout = run_cli(["check", "--thresholds", "default", "--matrix", str(matrix_path), "--db", str(db),
                                  "--junit", str(junit), "--jobs", JOBS, "--no-progress"])
    yield {"status": status, "stdout": stdout, "db": db, "junit": junit, "directory": directory}
    for name in MUTANT_OF.values():
        unregister(name)
    sys.modules.pop(MUTANT_PLUGIN, None)


def test_default_thresholds_hold_on_the_quick_matrix(gate_run):
    assert gate_run["status"] == 0, gate_run["stdout"]
    assert "FAIL" not in gate_run["stdout"]
    assert re.search(r"(\d+) checks: \1 passed, 0 failed", gate_run["stdout"])


def test_junit_report_has_one_case_per_check(gate_run):
    thresholds = load_thresholds("default")
    cases = junit_cases(gate_run["junit"])
    root = ElementTree.parse(gate_run["junit"]).getroot()
    assert int(root.get("tests")) == len(cases) and int(root.get("failures")) == 0
    numbers = {int(re.match(r"#(\d+) ", case.get("name")).group(1)) for case in cases}
    assert numbers == {bound.number for bound in thresholds.bounds}  # every bound was checked on some row
    assert not any(case.find("failure") is not None for case in cases)


def test_stored_results_give_the_same_verdict(gate_run):
    """--results reads the database the --matrix run kept; --format markdown gives a GitHub table."""
    status, stdout = run_cli(["check", "--thresholds", "default", "--results", str(gate_run["db"]),
                              "--format", "markdown"])
    assert status == 0
    assert stdout.splitlines()[0].startswith("| #")
    assert stdout.count("| pass") == len(junit_cases(gate_run["junit"]))


def test_shipped_bounds_state_their_basis():
    for bound in load_thresholds("default").bounds:
        assert bound.basis.startswith(("theory: ", "measured: ")), f"bound #{bound.number} has no basis"


def test_check_names_the_integrators_no_bound_checks(gate_run, capsys):
    """The shipped bounds select every quick-matrix integrator and neither mutant (``gate_run``): the note names
    the mutants, and only them, and is not a failure (a new built-in without bounds passes the gate)."""
    capsys.readouterr()
    status, _ = run_cli(["check", "--thresholds", "default", "--results", str(gate_run["db"])])
    assert status == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if "have no bound" in line]
    assert len(notes) == 1, notes
    assert notes[0].endswith(f"nothing checks them: {', '.join(sorted(MUTANT_OF.values()))}"), notes[0]


def test_wrong_integrators_fail_the_shipped_bounds(gate_run):
    """The shipped bounds of rk4 and verlet, retargeted to their mutants, fail on the mutants' rows."""
    shipped = tomllib.loads(DEFAULT_THRESHOLDS.read_text(encoding="utf-8"))
    retargeted = [{**table, "integrator": MUTANT_OF[table["integrator"]]} for table in shipped["bound"]
                  if isinstance(table.get("integrator"), str) and table["integrator"] in MUTANT_OF]
    thresholds = gate_run["directory"] / "mutants.toml"
    thresholds.write_text(toml_text({"bound": retargeted}), encoding="utf-8")
    junit = gate_run["directory"] / "mutants_junit.xml"
    status, stdout = run_cli(["check", "--thresholds", str(thresholds), "--results", str(gate_run["db"]),
                              "--junit", str(junit)])
    assert status == 1, stdout
    failed = [(case.get("classname"), case.get("name")) for case in junit_cases(junit)
              if case.find("failure") is not None]
    # Weights (1, 3, 1, 1)/6 make a second-order method (tests/check_mutants.py): both order fits fall below 3.5.
    for scene in ("seed_2min", "lab_3m_90s"):
        for column in ("reference_error", "precession_rate_ref_error_earth"):
            assert any(classname == f"check.{scene}.rk4_wrong_weights" and name.endswith(f"order of {column} >= 3.5")
                       for classname, name in failed), (scene, column, failed)
    # The explicit Coriolis kick opens the swing into an ellipse, which the spherical model turns into a fake
    # Airy precession (integrators/README.md "Rotating-frame Verlet").
    assert any(classname == "check.lab_3m_90s.verlet_naive_coriolis" and "precession_rate_ref_error" in name
               for classname, name in failed)
    assert re.search(r"bound #\d+ lab_3m_90s verlet_naive_coriolis \S+: precession_rate_ref_error_earth <= \S+ "
                     r"violated, measured", stdout)
    assert f"{len(failed)} failed" in stdout


# --- bad input: exit 2 before anything runs ------------------------------------------------------------------------


BAD_BOUNDS = {
    "unknown integrator": (['integrator = "rk5"', 'column = "reference_error"', "max = 1e-6"],
                           "unknown integrator 'rk5' (did you mean 'rk4'?)"),
    "unknown scene": (['scene = "pantheonn"', 'integrator = "rk4"', 'column = "reference_error"', "max = 1e-6"],
                      "unknown scene 'pantheonn' (did you mean 'pantheon'?)"),
    "unknown column": (['integrator = "rk4"', 'column = "reference_eror"', "max = 1e-6"],
                       "unknown column 'reference_eror' (did you mean 'reference_error'?)"),
    "no matching row": (['integrator = "rk4"', "kh = 0.3", 'column = "reference_error"', "max = 1e-6"],
                        "matches no row of matrix 'quick'"),
    "built-in scene not in the matrix": (['scene = "pantheon"', 'integrator = "rk4"', 'column = "nfev"', "max = 1"],
                                         "scene 'pantheon' has no rows in matrix 'quick'"),
    "absolute wall time": (['integrator = "rk4"', 'column = "wall_time_s"', "max = 1.0"],
                           "bound it only as max_ratio"),
    "order of an adaptive method": (['integrator = "cvode_bdf"', 'column = "reference_error"', "min_order = 4"],
                                    "cvode_bdf is adaptive"),
    "two kinds": (['integrator = "rk4"', 'column = "reference_error"', "max = 1e-6", "min = 1e-9"],
                  "give exactly one kind of bound"),
    "unknown key": (['integrator = "rk4"', 'column = "reference_error"', "maximum = 1e-6"],
                    "unknown key 'maximum'"),
}


@pytest.mark.parametrize("case", sorted(BAD_BOUNDS))
def test_bad_thresholds_exit_2_with_a_clear_message(case, tmp_path, capsys):
    lines, message = BAD_BOUNDS[case]
    if not any(line.startswith("scene") for line in lines):
        lines = ['scene = "seed_2min"', *lines]
    thresholds = write_toml_lines(tmp_path / "bad.toml", ["[[bound]]", *lines])
    status = main(["check", "--thresholds", str(thresholds), "--matrix", "quick", "--no-progress"])
    assert status == 2
    errors = capsys.readouterr().err
    assert message in errors, errors
    assert "Traceback" not in errors


def test_malformed_toml_exits_2(tmp_path, capsys):
    thresholds = write_toml_lines(tmp_path / "broken.toml", ["[[bound]]", 'scene = "seed_2min'])
    assert main(["check", "--thresholds", str(thresholds), "--matrix", "quick"]) == 2
    assert "not valid TOML" in capsys.readouterr().err


def test_documented_example_is_a_valid_thresholds_file():
    """The complete example of bench/README.md "The gate" parses and names only real scenes, integrators and
    columns (tests/test_docs.py also runs the documented examples)."""
    texts = [(ROOT / "bench" / "README.md").read_text(encoding="utf-8")]
    examples = [block for text in texts for block in re.findall(r"```toml\n(# thresholds example.*?)```", text, re.S)]
    assert examples, "the README's complete thresholds example is missing"
    thresholds = parse_thresholds(tomllib.loads(examples[0]), source="README example")
    from foucault_bench.bench.problems.scenes import SCENES

    for bound in thresholds.bounds:
        assert set(bound.selection.scenes) <= set(SCENES)
        assert set(bound.selection.integrators) <= set(REGISTRY)


# --- evaluation rules on hand-made rows -----------------------------------------------------------------------------


def made_up_row(**values) -> dict:
    """One results row with every column, NULL unless given."""
    row = dict.fromkeys(COLUMN_NAMES)
    row.update(scene="lab", family="runge-kutta", status="ok", message="", duration_s=10.0, n_out=11)
    row.update(values)
    return row


def made_up_thresholds(*bounds: dict):
    return parse_thresholds({"bound": [{"scene": "lab", **bound} for bound in bounds]}, source="test")


def test_ratio_bound_divides_by_the_other_integrator_of_the_same_run():
    frame = pd.DataFrame([
        made_up_row(integrator="fast", kh=0.1, step_s=0.1, wall_time_s=1.0),
        made_up_row(integrator="slow", kh=0.1, step_s=0.1, wall_time_s=3.0),
    ])
    thresholds = made_up_thresholds(
        {"integrator": "slow", "column": "wall_time_s", "max_ratio": 2.0, "relative_to": "fast"},
        {"integrator": "slow", "column": "wall_time_s", "max_ratio": 4.0, "relative_to": {"integrator": "fast",
                                                                                           "kh": 0.1}},
    )
    validate_against(thresholds, frame, what="made-up rows")
    failing, passing = evaluate(thresholds, frame)
    assert failing.measured == pytest.approx(3.0) and not failing.passed
    assert passing.passed and passing.margin == pytest.approx(4.0 / 3.0)


def test_ratio_bound_without_a_counterpart_row_is_bad_input():
    frame = pd.DataFrame([made_up_row(integrator="fast", kh=0.1, step_s=0.1, wall_time_s=1.0),
                          made_up_row(integrator="slow", kh=0.2, step_s=0.2, wall_time_s=3.0)])
    thresholds = made_up_thresholds(
        {"integrator": "slow", "column": "wall_time_s", "max_ratio": 2.0, "relative_to": "fast"})
    with pytest.raises(InputError, match="fast has no row to compare with at lab kh=0.2"):
        validate_against(thresholds, frame, what="made-up rows")


def test_a_run_that_is_not_ok_fails_value_bounds_and_says_why():
    frame = pd.DataFrame([made_up_row(integrator="rk4", kh=0.1, step_s=0.1, status="diverged",
                                      message="diverged after 3 steps", reference_error=1e-9)])
    outcomes = evaluate(made_up_thresholds({"integrator": "rk4", "column": "reference_error", "max": 1.0},
                                           {"integrator": "rk4", "status": "ok"}), frame)
    assert [outcome.passed for outcome in outcomes] == [False, False]
    assert "diverged after 3 steps" in outcomes[0].detail
    assert "FAIL" in render(outcomes, markdown=False)


def test_missing_value_fails_and_margins_follow_the_bound_direction():
    frame = pd.DataFrame([made_up_row(integrator="rk4", kh=0.1, step_s=0.1, reference_error=None,
                                      energy_drift_per_s=-2e-9)])
    missing, drift, signed = evaluate(made_up_thresholds(
        {"integrator": "rk4", "column": "reference_error", "max": 1.0},
        {"integrator": "rk4", "column": "energy_drift_per_s", "max_abs": 1e-9},
        {"integrator": "rk4", "column": "energy_drift_per_s", "min": -1e-9}), frame)
    assert not missing.passed and math.isnan(missing.measured)
    assert not drift.passed and drift.margin == pytest.approx(0.5)
    assert not signed.passed and signed.margin == pytest.approx(-1e-9)  # a difference: the value is negative
    assert headroom("min", 4.0, 3.5) == (pytest.approx(4.0 / 3.5), True)


def test_a_bound_on_a_column_the_matrix_left_out_says_where_that_column_is_computed():
    """A bound on ``energy_max_rel_error_steps`` over a row without it (a matrix with ``step_energy = false``)
    fails and says that the column needs ``step_energy = true``; another missing column says only that nothing was
    measured."""
    frame = pd.DataFrame([made_up_row(integrator="rk4", kh=0.1, step_s=0.1)])
    left_out, missing = evaluate(made_up_thresholds(
        {"integrator": "rk4", "column": "energy_max_rel_error_steps", "max": 1.0},
        {"integrator": "rk4", "column": "reference_error", "max": 1.0}), frame)
    assert not left_out.passed and "step_energy = true" in left_out.detail
    assert not missing.passed and missing.detail == "no finite value measured"


def test_order_is_fitted_on_error_columns_only():
    with pytest.raises(InputError, match="cannot take a min_order bound"):
        made_up_thresholds({"integrator": "rk4", "column": "energy_drift_per_s", "min_order": 4})
    assert "energy_drift_per_s" not in ERROR_COLUMNS


# --- what a stored or named matrix is ---------------------------------------------------------------------------


def _stored_run(db: Path, rows: int) -> str:
    """A matrix run of 2 planned runs in ``db`` with ``rows`` of them stored and its status left 'running' (as
    while it runs, or after a kill): the rows are hand-made, the provenance is the store's own."""
    from foucault_bench.bench.run.matrix import parse_matrix
    from foucault_bench.bench.run.store import ResultsStore

    matrix = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.2, 0.1]})
    with ResultsStore(db) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        for spec in matrix.runs[:rows]:
            store.write_run(made_up_row(scene="seed_2min", integrator="rk4", kh=spec.kh, step_s=spec.step_s,
                                        matrix_id=matrix_id, run_key=spec.run_key, precession_rate_ref_error=1e-9))
    return matrix_id


GATE_ON_STORED = ['[[bound]]', 'scene = "seed_2min"', 'integrator = "rk4"', 'column = "precession_rate_ref_error"',
                  'max = 1e-6']


def test_a_matrix_run_that_is_not_finished_is_refused_naming_its_status(tmp_path, capsys):
    """A running (or killed) matrix run checked 1 of 2 rows and passed; now exit 2 naming the status and the
    rows stored, for 'running' and 'interrupted'; --allow-unfinished checks the rows there are, with a note."""
    from foucault_bench.bench.run.store import ResultsStore

    db = tmp_path / "partial.sqlite"
    matrix_id = _stored_run(db, rows=1)
    thresholds = write_toml_lines(tmp_path / "gate.toml", GATE_ON_STORED)
    for status in ("running", "interrupted"):
        if status == "interrupted":
            with ResultsStore(db) as store:
                store.finish_matrix_run(matrix_id, "interrupted")
        before = db.read_bytes()
        assert run_cli(["check", "--thresholds", str(thresholds), "--results", str(db)]) == (2, "")
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert f"is {status!r}, not 'finished': 1 of 2 planned rows are stored" in line and "--allow-unfinished" in line
        assert db.read_bytes() == before
    status, stdout = run_cli(["check", "--thresholds", str(thresholds), "--results", str(db), "--allow-unfinished"])
    assert status == 0 and "pass" in stdout.lower()
    assert "note: " in capsys.readouterr().err
    with ResultsStore(db) as store:
        store.finish_matrix_run(matrix_id)
    assert run_cli(["check", "--thresholds", str(thresholds), "--results", str(db)])[0] == 0


def test_the_matrix_a_thresholds_file_names_is_found_beside_it_and_nowhere_else(tmp_path, monkeypatch, capsys):
    """``matrix = "m.toml"`` missing beside the thresholds file fell back to ./m.toml in the current folder;
    now it is exit 2 naming the path beside the file, and a file beside it is the one read."""
    gate, elsewhere = tmp_path / "gate", tmp_path / "elsewhere"
    gate.mkdir()
    elsewhere.mkdir()
    (elsewhere / "m.toml").write_text('scenes = ["seed_2min"]\nintegrators = ["from_the_current_folder"]\nkh = [0.2]\n')
    thresholds = write_toml_lines(gate / "gate.toml", ['matrix = "m.toml"', *GATE_ON_STORED])
    monkeypatch.chdir(elsewhere)
    assert main(["check", "--thresholds", str(thresholds), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"there is no file {gate / 'm.toml'}" in err and "from_the_current_folder" not in err
    (gate / "m.toml").write_text('scenes = ["seed_2min"]\nintegrators = ["from_beside_the_file"]\nkh = [0.2]\n')
    assert main(["check", "--thresholds", str(thresholds), "--no-progress"]) == 2
    assert "'from_beside_the_file'" in capsys.readouterr().err
    built_in = load_thresholds(write_toml_lines(gate / "named.toml", ['matrix = "quick"', *GATE_ON_STORED]))
    assert built_in.matrix_to_run() == "quick"  # a built-in name, with no file of that name beside


def test_junit_xml_holds_texts_xml_cannot_as_their_escapes() -> None:
    """A basis, scene or integrator name with characters XML 1.0 cannot hold (control characters, a terminal's
    escape) still gives a file every XML parser reads, those characters written as their escapes; tabs, newlines
    and the rest of Unicode are kept."""
    from foucault_bench.bench.gate.evaluate import Outcome
    from foucault_bench.bench.gate.render import junit_xml
    from foucault_bench.bench.gate.thresholds import Bound, Selection

    bound = Bound(number=1, selection=Selection(scenes=("s\x01",)), kind="max", limit=1e-6,
                  column="reference_error", basis="theory:\x1b[31m red\x1b[0m, é\tand ≤ <&>")
    outcome = Outcome(bound=bound, scene="s\x01", integrator="rk\x0b4", setting="kh=0.1", measured=2e-6,
                      margin=0.5, passed=False, margin_is_factor=True)
    text = ElementTree.tostring(junit_xml([outcome], suite="x\x00").getroot(), encoding="unicode")
    root = ElementTree.fromstring(text)  # a parser refuses a file holding any of them
    case = root.find("testsuite/testcase")
    assert case is not None and case.get("classname") == "check.s\\x01.rk\\x0b4"
    assert root.find("testsuite").get("name") == "x\\x00"
    assert "basis: theory:\\x1b[31m red\\x1b[0m, é\tand ≤ <&>" in case.find("system-out").text
