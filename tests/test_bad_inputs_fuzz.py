"""Bad input, table-driven and at random: every case goes through the real command line (``bench.cli.main``
with an argv, in this process) and must end with exit status 2, one ``error:`` line per problem naming it, no
traceback, and no file created or changed anywhere under the case's folder (which is also the current folder
and the reference cache, so a default output path or a computed reference would show).

``CASES`` gathers the bad inputs found so far (matrices, inline scenes, thresholds files, command options,
names, physical limits, sizes); the random section mutates valid matrix and thresholds documents and simulate
options with a seeded ``random.Random`` (the same cases on every run: no flakiness, no extra dependency) and
holds each outcome to the same rules. Argparse's own refusals (a value of the wrong type) print a usage line
before their one error line and exit 2 through ``SystemExit``; those cases say so (``argparse=True``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import random
import shutil
import sqlite3
from pathlib import Path
from typing import Any, Callable

import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.gate.thresholds import parse_thresholds
from foucault_bench.bench.problems.reference import CACHE_ENVIRONMENT_VARIABLE
from foucault_bench.bench.problems.scenes import MAX_SCENE_NAME_LENGTH
from foucault_bench.bench.run.matrix import MAX_RUNS, Matrix, parse_matrix

TINY = 'scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = [0.2]\n'
"""A valid one-run matrix: the base that cases change one thing of."""
BOUND = '[[bound]]\nscene = "seed_2min"\nintegrator = "rk4"\ncolumn = "reference_error"\nmax = 1e-3\n'
"""A valid bound for thresholds cases."""
ROOT_PROBE = Path("/nonexistent-foucault-bench-fuzz")
"""A folder at the filesystem root that no case may create (``simulate --save`` did)."""


@dataclasses.dataclass(frozen=True)
class Case:
    """One bad input: ``argv`` (``{d}`` is the case's folder), files written there first (text, or bytes),
    an optional ``setup(folder)``, and the substrings the error lines must hold, each in some line; ``problems``
    is how many error lines there must be."""

    name: str
    argv: tuple[str, ...]
    expected: tuple[str, ...]
    files: tuple[tuple[str, str | bytes], ...] = ()
    setup: Callable[[Path], None] | None = None
    problems: int = 1
    argparse: bool = False


def matrix_case(name: str, text: str | bytes, *expected: str, problems: int = 1) -> Case:
    """``run`` on a matrix file holding ``text``."""
    return Case(name, ("run", "--matrix", "{d}/m.toml", "--db", "{d}/results.sqlite", "--no-progress"), expected,
                files=(("m.toml", text),), problems=problems)


def scene_case(name: str, fields: str, *expected: str, scene: str = "lab") -> Case:
    """``run`` on a matrix with one inline scene based on seed_2min, with ``fields`` (TOML lines) changed."""
    return matrix_case(name, f'integrators = ["rk4"]\nkh = [0.2]\n[scene.{scene}]\nbase = "seed_2min"\n{fields}\n',
                       *expected)


def thresholds_case(name: str, text: str, *expected: str, extra: tuple[tuple[str, str], ...] = ()) -> Case:
    return Case(name, ("check", "--thresholds", "{d}/t.toml", "--matrix", "{d}/m.toml", "--no-progress"), expected,
                files=(("t.toml", text), ("m.toml", TINY), *extra))


def _unfinished_run(folder: Path) -> None:
    """A database holding a matrix run left 'running' with 1 of its 2 rows (as after a kill)."""
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.schema import COLUMN_NAMES

    matrix = parse_matrix({"scenes": ["seed_2min"], "integrators": ["rk4"], "kh": [0.2, 0.1]})
    with ResultsStore(folder / "partial.sqlite") as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        row = dict.fromkeys(COLUMN_NAMES)
        row.update(matrix_id=matrix_id, run_key=matrix.runs[0].run_key, scene="seed_2min", integrator="rk4",
                   family="runge-kutta", status="ok", kh=0.2, reference_error=1e-9)
        store.write_run(row)


def _foreign_database(folder: Path) -> None:
    with sqlite3.connect(folder / "foreign.sqlite") as connection:
        connection.execute("CREATE TABLE customers (name TEXT)")
    connection.close()


AZIMUTHS = 400
SWEEP = [0.2 * (1.0 - index / 1000) for index in range(MAX_RUNS // AZIMUTHS + 1)]
OVERSIZED = (f'scenes = ["seed_2min"]\nintegrators = ["rk4"]\nkh = {SWEEP!r}\n'
             f'release_azimuth_deg = {list(range(AZIMUTHS))!r}\n')
"""400 azimuth variants × 251 steps: 100 400 runs, more than MAX_RUNS, from a small file."""

CASES: tuple[Case, ...] = (
    # --- matrix files: reading ---
    matrix_case("invalid TOML", 'scenes = ["seed_2min"\nintegrators = ["rk4"]\n', "not valid TOML", "line"),
    matrix_case("not UTF-8", b"\xff\xfe not text", "cannot read the matrix file"),
    Case("missing matrix file", ("run", "--matrix", "{d}/absent.toml", "--db", "{d}/r.sqlite"), ("absent.toml",)),
    Case("misspelt built-in matrix", ("run", "--matrix", "quik", "--db", "{d}/r.sqlite"), ("did you mean 'quick'",)),
    Case("a folder as the matrix", ("run", "--matrix", "{d}", "--db", "{d}/r.sqlite"),
         ("neither a readable file nor a built-in",)),
    # --- matrix files: keys and names ---
    matrix_case("unknown top-level key", TINY + "colour = 1\n", "unknown key 'colour'"),
    matrix_case("unknown scene", TINY.replace("seed_2min", "seed_2mn"), "unknown scene 'seed_2mn'",
                "did you mean 'seed_2min'"),
    matrix_case("unknown integrator", TINY.replace("rk4", "rk5"), "unknown integrator 'rk5'"),
    matrix_case("empty integrator list", 'scenes = ["seed_2min"]\nintegrators = []\nkh = [0.2]\n',
                "integrators: the list is empty"),
    matrix_case("no scenes", 'integrators = ["rk4"]\nkh = [0.2]\n', "no scenes"),
    matrix_case("the reference integrator", 'scenes = ["seed_2min"]\nintegrators = ["heyoka_taylor_quad"]\n'
                'tol = [1e-9]\n', "computes the references"),
    matrix_case("unimportable plug-in", TINY + 'plugins = ["no_such_module_for_fuzz"]\n', "cannot import"),
    matrix_case("plug-in registering nothing", TINY + 'plugins = ["json"]\n', "registers no integrator"),
    matrix_case("integrator listed twice", 'scenes = ["seed_2min"]\nintegrators = ["rk4", "rk4"]\nkh = [0.2]\n',
                "listed more than once"),
    # --- matrix files: settings ---
    matrix_case("kh zero", TINY.replace("0.2", "0.0"), "step size must be > 0"),
    matrix_case("kh negative", TINY.replace("0.2", "-0.1"), "step size must be > 0"),
    matrix_case("kh infinite", TINY.replace("0.2", "inf"), "step size must be > 0"),
    matrix_case("kh nan", TINY.replace("0.2", "nan"), "step size must be > 0"),
    matrix_case("kh a string", TINY.replace("0.2", '"fast"'), "numbers a float can hold"),
    matrix_case("kh an integer no float holds", TINY.replace("0.2", "1" + "0" * 400), "numbers a float can hold",
                "(401 characters)"),
    matrix_case("kh too coarse", TINY.replace("0.2", "2.0"), "at most one output interval"),
    matrix_case("kh needing 1e11 steps", TINY.replace("0.2", "1e-9"), "steps in scene 'seed_2min'"),
    matrix_case("kh listed twice", TINY.replace("[0.2]", "[0.2, 0.2]"), "more than once"),
    matrix_case("tolerance one", 'scenes = ["seed_2min"]\nintegrators = ["cvode_bdf"]\ntol = [1.0]\n',
                "tolerance must lie in (0, 1)"),
    matrix_case("tolerance below 2^-53", 'scenes = ["seed_2min"]\nintegrators = ["cvode_bdf"]\ntol = [1e-300]\n',
                "below the double-precision unit roundoff"),
    matrix_case("tol for a fixed-step method", TINY + "[override.rk4]\ntol = [1e-6]\n", "tol does not apply"),
    matrix_case("shared tol unused", TINY + "tol = [1e-6]\n", "tol is given but no listed adaptive integrator"),
    matrix_case("more runs than MAX_RUNS", OVERSIZED, f"expands to {AZIMUTHS * len(SWEEP)} runs"),
    # --- matrix files: timing ---
    matrix_case("run timeout beyond poll(2)", TINY + "[timing]\nrun_timeout_s = 3e6\n", "more than 1e+06 s"),
    matrix_case("run timeout negative", TINY + "[timing]\nrun_timeout_s = -1\n", "finite number of seconds > 0"),
    matrix_case("timing key misspelt", TINY + "[timing]\nmin_repeat = 2\n", "did you mean 'min_repeats'"),
    matrix_case("min_repeats not an integer", TINY + "[timing]\nmin_repeats = 2.5\n", "must be an integer"),
    matrix_case("min_repeats no float holds", TINY + "[timing]\nmin_repeats = 1" + "0" * 400 + "\n",
                "must be an integer"),
    # --- inline scenes, release azimuths ---
    scene_case("latitude beyond the pole", "latitude_deg = 95.0", "latitude_deg", "95"),
    scene_case("amplitude not below the length", "amplitude_m = 67.0", "less than length_m"),
    scene_case("scene key misspelt", "lenght_m = 2.0", "did you mean 'length_m'"),
    scene_case("length no float holds", "length_m = 1" + "0" * 400, "length_m must be a finite number"),
    scene_case("release at 1e300 m/s", "release_velocity_m_s = [1e300, 0.0]", "pivot's height", "must stay below"),
    scene_case("release velocity not a pair", "release_velocity_m_s = [1.0]", "a pair [vx, vy]"),
    scene_case("Earth turning at 1e10 rad/s", "earth_rate_rad_s = 1e10", "must be below the pendulum's own frequency"),
    scene_case("grid too coarse", "output_interval_s = 10.0", "too coarse"),
    scene_case("duration not whole intervals", "duration_s = 121.0", "not a whole number of output intervals"),
    scene_case("name ending in a newline", "", "may hold only letters", scene='"lab\\n"'),
    scene_case("name with a slash", "", "may hold only letters", scene='"lab/x"'),
    scene_case("name of 250 characters", "", "more than 64", scene="n" * 250),
    scene_case("name of 130 capitals", "", "more than 64", scene="N" * 130),
    scene_case("name of a built-in scene", "", "taken by a built-in scene", scene="pantheon"),
    matrix_case("azimuth listed twice", TINY + "release_azimuth_deg = [45, 45.0]\n", "listed more than once"),
    matrix_case("azimuth variant name too long",
                f'integrators = ["rk4"]\nkh = [0.2]\nrelease_azimuth_deg = [0.125]\n'
                f'[scene.{"a" * (MAX_SCENE_NAME_LENGTH - 4)}]\nbase = "seed_2min"\n',
                f"-az0.125' has {MAX_SCENE_NAME_LENGTH + 4} characters"),
    matrix_case("azimuth not a number", TINY + 'release_azimuth_deg = ["east"]\n', "list of finite numbers"),
    # --- run options ---
    Case("run timeout 3e6 s", ("run", "--matrix", "{d}/m.toml", "--db", "{d}/r.sqlite", "--run-timeout", "3e6"),
         ("--run-timeout = 3e+06 s is more than 1e+06 s",), files=(("m.toml", TINY),)),
    Case("run timeout nan", ("run", "--matrix", "{d}/m.toml", "--db", "{d}/r.sqlite", "--run-timeout", "nan"),
         ("--run-timeout must be a finite number",), files=(("m.toml", TINY),)),
    Case("run timeout not a number", ("run", "--run-timeout", "soon"), ("invalid float value",), argparse=True),
    Case("jobs zero", ("run", "--matrix", "{d}/m.toml", "--db", "{d}/r.sqlite", "--jobs", "0"),
         ("--jobs must be at least 1",), files=(("m.toml", TINY),)),
    Case("db is a folder", ("run", "--matrix", "{d}/m.toml", "--db", "{d}"), ("is a folder",),
         files=(("m.toml", TINY),)),
    Case("db under a file", ("run", "--matrix", "{d}/m.toml", "--db", "{d}/m.toml/r.sqlite"), ("--db",),
         files=(("m.toml", TINY),)),
    # --- results and report ---
    Case("results on a missing database", ("results", "--db", "{d}/none.sqlite"), ("no results database",)),
    Case("an empty --csv", ("results", "--db", "{d}/none.sqlite", "--csv", ""), ("--csv: an empty value",)),
    Case("an empty --results=", ("check", "--thresholds", "default", "--results="), ("--results: an empty value",)),
    Case("an empty --db and --scheduler", ("run", "--matrix", "quick", "--db", "", "--scheduler", ""),
         ("--db: an empty value", "--scheduler: an empty value"), problems=2),
    Case("an empty --repo", ("history", "--db", "{d}/none.sqlite", "--repo", ""), ("--repo: an empty value",)),
    Case("results on a foreign database", ("results", "--db", "{d}/foreign.sqlite"), ("foreign.sqlite",),
         setup=_foreign_database),
    Case("csv in a missing folder", ("results", "--db", "{d}/none.sqlite", "--csv", "{d}/no/rows.csv"),
         ("does not exist",)),
    Case("report targets not positive", ("report", "--db", "{d}/none.sqlite", "--out", "{d}/r", "--targets", "0"),
         ("--targets",)),
    Case("report into a file", ("report", "--db", "{d}/none.sqlite", "--out", "{d}/m.toml"),
         ("exists and is not a folder",), files=(("m.toml", TINY),)),
    # --- check: thresholds files and what they are checked on ---
    thresholds_case("thresholds invalid TOML", "[[bound]]\nscene = \"seed_2min\n", "not valid TOML"),
    thresholds_case("bound without a kind", BOUND.replace("max = 1e-3\n", ""), "give exactly one kind of bound"),
    thresholds_case("bound of an unknown column", BOUND.replace("reference_error", "referenc_error"),
                    "unknown column 'referenc_error'"),
    thresholds_case("bound on wall time", BOUND.replace("reference_error", "wall_time_s"),
                    "depends on the machine"),
    thresholds_case("bound selecting no row", BOUND.replace('"rk4"', '"verlet"'), "has no rows"),
    thresholds_case("bound with kh 0", BOUND + "kh = 0.0\n", "kh must be a number > 0"),
    Case("thresholds matrix missing beside the file", ("check", "--thresholds", "{d}/gate/t.toml"),
         ("there is no file", "relative to the file's own folder"),
         files=(("gate/t.toml", 'matrix = "m.toml"\n' + BOUND), ("m.toml", TINY))),
    Case("check an unfinished matrix run", ("check", "--thresholds", "{d}/t.toml", "--results", "{d}/partial.sqlite"),
         ("is 'running', not 'finished': 1 of 2 planned rows",), files=(("t.toml", BOUND),), setup=_unfinished_run),
    Case("allow-unfinished without results", ("check", "--thresholds", "{d}/t.toml", "--allow-unfinished"),
         ("--allow-unfinished is for a stored matrix run",), files=(("t.toml", BOUND),)),
    Case("matrix id without results", ("check", "--thresholds", "{d}/t.toml", "--matrix-id", "x"),
         ("--matrix-id selects a stored run",), files=(("t.toml", BOUND),)),
    Case("junit in a missing folder", ("check", "--thresholds", "default", "--junit", "{d}/no/j.xml"),
         ("does not exist",)),
    Case("check run timeout beyond poll(2)", ("check", "--thresholds", "{d}/t.toml", "--matrix", "{d}/m.toml",
                                              "--run-timeout", "1e7", "--no-progress"),
         ("more than 1e+06 s",), files=(("t.toml", BOUND), ("m.toml", TINY))),
    # --- simulate ---
    Case("simulate tolerance 1e-300", ("simulate", "--integrator", "cvode_bdf", "--tol", "1e-300"),
         ("--tol: tol = 1e-300 is below the double-precision unit roundoff",)),
    Case("simulate kh 1e-12", ("simulate", "--kh", "1e-12"), ("steps in this simulation",)),
    Case("simulate kh beyond one output interval", ("simulate", "--kh", "0.5"), ("at most one output interval",)),
    Case("simulate 10^8 frames", ("simulate", "--save", "{d}/a.gif", "--frames", "100000000"),
         ("--frames must lie in [2, 200]",)),
    Case("simulate 1000 fps", ("simulate", "--save", "{d}/a.gif", "--fps", "1000"), ("--fps must lie in [1, 50]",)),
    Case("simulate save at the root", ("simulate", "--save", f"{ROOT_PROBE}/x.gif"), ("does not exist",)),
    Case("simulate save in a missing folder", ("simulate", "--save", "{d}/missing/x.gif"), ("does not exist",)),
    Case("simulate save as avi", ("simulate", "--save", "{d}/x.avi"), ("must end in .gif or .mp4",)),
    Case("simulate save onto a folder", ("simulate", "--save", "{d}/folder.gif"), ("is a folder",),
         files=(("folder.gif/keep", ""),)),
    Case("simulate Earth at 1e10 times", ("simulate", "--earth-rate", "1e10"), ("pendulum's own frequency",)),
    Case("simulate hours 1e306", ("simulate", "--hours", "1e306"), ("output points, more than",)),
    Case("simulate latitude nan", ("simulate", "--latitude", "nan"), ("latitude_deg",)),
    Case("simulate amplitude above length", ("simulate", "--length", "2", "--amplitude", "3"), ("amplitude_m",)),
    Case("simulate every problem at once", ("simulate", "--integrator", "nope", "--hours", "-1", "--save", "{d}/x.avi",
                                            "--frames", "1"),
         ("unknown integrator 'nope'", "--hours", ".gif or .mp4", "--frames"), problems=4),
    Case("simulate frames not an integer", ("simulate", "--frames", "1e8"), ("invalid int value",), argparse=True),
    Case("results writing over its own database", ("results", "--db", "{d}/partial.sqlite", "--csv",
                                                   "{d}/partial.sqlite"), ("partial.sqlite",), setup=_unfinished_run),
    Case("seed into a folder under a file", ("seed", "--out", "{d}/m.toml/seed"), ("--out",), files=(("m.toml", TINY),)),
    # --- advise ---
    Case("advise without a database", ("advise", "--scene", "pantheon", "--target", "reference_error=1e-6",
                                       "--no-search", "--db", "{d}/typo/x.sqlite"), ("x.sqlite",)),
    Case("advise unknown scene", ("advise", "--scene", "nope", "--target", "reference_error=1e-6", "--no-search",
                                  "--db", "{d}/none.sqlite"), ("unknown scene 'nope'",)),
    Case("advise malformed target", ("advise", "--scene", "pantheon", "--target", "bogus", "--no-search",
                                     "--db", "{d}/none.sqlite"), ("METRIC=VALUE",)),
    Case("advise negative target", ("advise", "--scene", "pantheon", "--target", "reference_error=-1", "--no-search",
                                    "--db", "{d}/none.sqlite"), ("> 0",)),
)


def snapshot(folder: Path) -> dict[str, str]:
    """Every path under ``folder`` with its kind and, for a file, the SHA-256 of its bytes; but for the shared-
    memory index and empty log every SQLite reader of a write-ahead-log database makes beside it
    (sqlite.org/wal.html; ``bench.run.store_schema.read_only_connection``), which hold no data."""
    def reader_file(path: Path) -> bool:
        database = Path(str(path)[:-4])
        return (path.name.endswith("-shm") or (path.name.endswith("-wal") and path.stat().st_size == 0)) \
            and database.is_file()

    return {str(path.relative_to(folder)): "folder" if path.is_dir() else hashlib.sha256(path.read_bytes()).hexdigest()
            for path in sorted(folder.rglob("*")) if not reader_file(path)}


def run_refused(argv: list[str], capsys, *, argparse: bool = False) -> list[str]:
    """Run the command line; check exit 2 and no traceback; return the error lines (every line of stderr is
    one, but for argparse's usage lines)."""
    try:
        status = cli_main(argv)
    except SystemExit as exit_:  # argparse
        status = exit_.code
    captured = capsys.readouterr()
    assert status == 2, (argv, status, captured.err)
    assert "Traceback" not in captured.err and "Traceback" not in captured.out, captured.err
    lines = captured.err.strip().splitlines()
    errors = [line for line in lines if line.startswith(f"foucault-bench {argv[0]}: error: ")]
    if argparse:
        assert errors and lines[0].startswith("usage:"), lines
    else:
        assert errors == lines, lines  # nothing but error lines: no half-done work reported
    return errors


@pytest.fixture
def case_folder(tmp_path, monkeypatch) -> Path:
    """The case's folder: also the current folder and the reference cache."""
    folder = tmp_path / "case"
    folder.mkdir()
    monkeypatch.chdir(folder)
    monkeypatch.setenv(CACHE_ENVIRONMENT_VARIABLE, str(folder / "cache"))
    return folder


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_bad_input_is_one_line_per_problem_and_changes_nothing(case: Case, case_folder: Path, capsys) -> None:
    for name, content in case.files:
        path = case_folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    if case.setup is not None:
        case.setup(case_folder)
    before = snapshot(case_folder)
    argv = [part.replace("{d}", str(case_folder)) for part in case.argv]
    try:
        errors = run_refused(argv, capsys, argparse=case.argparse)
    finally:
        root_made = ROOT_PROBE.exists()
        if root_made:
            shutil.rmtree(ROOT_PROBE)
    assert not root_made, f"{ROOT_PROBE} was created"
    assert len(errors) == case.problems, errors
    for piece in case.expected:
        assert any(piece in line for line in errors), (piece, errors)
    assert all(len(line) < 1000 for line in errors), errors
    assert snapshot(case_folder) == before


# --- at random: seeded mutations of valid documents ------------------------------------------------------------

NASTY_VALUES: tuple[Any, ...] = (
    0, -1, 0.0, -0.0, 1e-300, 1e300, 1e10, 2**63, 10**400, math.nan, math.inf, -math.inf, True, "", "text",
    "x" * 2000, [], [0], [-1.0], [[0.1]], ["a"], {}, {"a": 1}, 1e-17, 0.5, 45.0000001,
)
"""Values a careless or hostile file may hold where a number, a name, a list or a table belongs."""

VALID_MATRIX: dict[str, Any] = {
    "name": "fuzz", "description": "a valid matrix that the mutations start from",
    "scenes": ["seed_2min"], "integrators": ["rk4", "cvode_bdf"], "kh": [0.2, 0.1], "tol": [1e-6],
    "release_azimuth_deg": [0.0, 90.0],
    "scene": {"lab": {"base": "lab_3m", "duration_s": 30.0, "amplitude_m": 0.2, "release_velocity_m_s": [0.0, 0.1],
                      "earth_rate_rad_s": 7.29e-5, "latitude_deg": 40.0}},
    "override": {"rk4": {"kh": [0.1]}},
    "timing": {"min_repeats": 1, "run_timeout_s": 60.0},
}
VALID_THRESHOLDS: dict[str, Any] = {
    "description": "a valid thresholds file", "matrix": "quick",
    "bound": [{"scene": "seed_2min", "integrator": "rk4", "column": "reference_error", "max": 1e-3, "kh": 0.2},
              {"scene": "seed_2min", "family": "runge-kutta", "column": "reference_error", "min_order": 3.0},
              {"scene": "seed_2min", "integrator": "rk4", "column": "nfev", "max_ratio": 2.0,
               "relative_to": {"integrator": "verlet", "kh": 0.2}}],
}


def mutate(document: Any, rng: random.Random, depth: int = 0) -> Any:
    """A copy of ``document`` with one thing changed somewhere inside it: a value replaced by a nasty one, a
    key removed or misspelt, an entry added to a list."""
    if isinstance(document, dict) and document and (depth == 0 or rng.random() < 0.7):
        key = rng.choice(sorted(document))
        changed = dict(document)
        action = rng.random()
        if action < 0.15:
            del changed[key]
        elif action < 0.25:
            changed[key[:-1] or "x"] = changed.pop(key)
        elif action < 0.6 and isinstance(document[key], (dict, list)):
            changed[key] = mutate(document[key], rng, depth + 1)
        else:
            changed[key] = rng.choice(NASTY_VALUES)
        return changed
    if isinstance(document, list) and document and rng.random() < 0.8:
        changed = list(document)
        index = rng.randrange(len(changed))
        if rng.random() < 0.3:
            changed.append(changed[index])
        elif isinstance(changed[index], (dict, list)):
            changed[index] = mutate(changed[index], rng, depth + 1)
        else:
            changed[index] = rng.choice(NASTY_VALUES)
        return changed
    return rng.choice(NASTY_VALUES)


def assert_refused_cleanly(error: InputError) -> None:
    assert error.problems and all(isinstance(problem, str) and problem and "\n" not in problem
                                  and len(problem) < 1000 for problem in error.problems), error.problems


@pytest.mark.parametrize("seed", range(4))
def test_random_matrices_are_valid_or_refused_one_line_per_problem(seed: int) -> None:
    """300 mutations per seed, one or two changes each, through ``parse_matrix``: a Matrix, or an InputError
    whose problems are short single lines; never any other exception."""
    rng = random.Random(seed)
    for _ in range(300):
        document = mutate(VALID_MATRIX, rng)
        if rng.random() < 0.5:
            document = mutate(document, rng)
        try:
            matrix = parse_matrix(document, source="fuzz")
        except InputError as error:
            assert_refused_cleanly(error)
        else:
            assert isinstance(matrix, Matrix) and matrix.runs and len(matrix.runs) <= MAX_RUNS


@pytest.mark.parametrize("seed", range(2))
def test_random_thresholds_are_valid_or_refused_one_line_per_problem(seed: int) -> None:
    rng = random.Random(seed)
    for _ in range(300):
        try:
            parse_thresholds(mutate(VALID_THRESHOLDS, rng), source="fuzz")
        except InputError as error:
            assert_refused_cleanly(error)


SIMULATE_OPTIONS = ("--hours", "--kh", "--tol", "--earth-rate", "--latitude", "--length", "--amplitude")
NASTY_NUMBERS = ("0", "-1", "-0", "1e-300", "1e300", "1e10", "nan", "inf", "-inf", "1e-17", "0.5", "90.0001", "3")


def test_random_simulate_options_are_valid_or_refused_before_any_work(monkeypatch) -> None:
    """Random values of simulate's numeric options: valid settings or an InputError of single lines, always
    before anything is simulated (the simulation is made an error here)."""
    import argparse

    import foucault_bench.reports.simulate as simulate_module
    from foucault_bench.bench.commands.simulate import add_arguments, settings_from_args

    monkeypatch.setattr(simulate_module, "simulate", lambda *_: pytest.fail("simulated during validation"))
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    rng = random.Random(0)
    for _ in range(200):
        argv = ["--integrator", rng.choice(["verlet", "rk4", "cvode_bdf", "scipy_rk45"])]
        for option in rng.sample(SIMULATE_OPTIONS, rng.randint(1, 3)):
            argv.append(f"{option}={rng.choice(NASTY_NUMBERS)}")  # "=": a value may start with "-"
        try:
            settings_from_args(parser.parse_args(argv))
        except InputError as error:
            assert_refused_cleanly(error)


def test_random_matrix_files_through_the_command_line_change_nothing(case_folder: Path, capsys) -> None:
    """A few of the random matrices as files through ``run``: each refused one is exit 2, one line per problem,
    no file created (the database is never opened); a valid one is not run here (it would start work)."""
    import tomllib

    from test_check import toml_text

    rng = random.Random(7)
    refused = 0
    while refused < 25:
        document = mutate(VALID_MATRIX, rng)
        try:
            text = toml_text(document)
            if tomllib.loads(text) != document:
                continue  # a value TOML cannot hold as written (nan, 10**400, …): the document tests cover it
        except (tomllib.TOMLDecodeError, ValueError, TypeError):
            continue
        try:
            parse_matrix(document, source="fuzz")
            continue  # valid: running it would start work
        except InputError as error:
            problems = len(error.problems)
        path = case_folder / "m.toml"
        path.write_text(text, encoding="utf-8")
        before = snapshot(case_folder)
        errors = run_refused(["run", "--matrix", str(path), "--db", str(case_folder / "r.sqlite"), "--no-progress"],
                             capsys)
        assert len(errors) == problems, errors
        assert snapshot(case_folder) == before
        refused += 1
