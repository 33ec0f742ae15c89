"""The documentation is true to the code: every TOML example in the READMEs loads (and the cheap ones run), every
relative link and cited path exists, every cited section exists, the README's test command is the one CI runs,
and nothing cites a file that is not in the repository."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import tomllib
from pathlib import Path

import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.gate.select import planned_rows, validate_against
from foucault_bench.bench.gate.thresholds import load_thresholds
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.bench.schema import markdown_table
from foucault_bench.reports.document import REFERENCE_DOCS, copy_reference_docs

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DOCS = tuple(ROOT / package / "README.md" for package in REFERENCE_DOCS)
DOCS = (ROOT / "README.md", *PACKAGE_DOCS)

CHEAP_SCENE_S = 300.0
"""A documented matrix whose scenes all last at most this long (seconds of pendulum time) is run, not only loaded."""

TOML_BLOCK = re.compile(r"```toml\n(.*?)```", re.S)
EXAMPLE_NAME = re.compile(r"^# (matrix|thresholds) example: (\S+\.toml)", re.M)
CITATION = re.compile(
    r"((?:docs/)?(?:models|integrators|bench|reports)/README\.md)[`)\]]*[ ,]*(?:\\?\"([^\"\\]+)\\?\"|'([^']+)')")
MARKDOWN_LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
CODE_SPAN = re.compile(r"`([^`\s]+)`")
PLACEHOLDER = re.compile(r"\b(NAME|FILE|DIR|PATH|MODULE|ID)\b")
"""Upper-case words in a documented path stand for the reader's own name (``integrators/NAME.py``)."""
FORBIDDEN = re.compile("|".join(["PHYS" + "ICS", "sha" + "red/", r"\.\./" + "seed"]))
"""Names of files outside the repository that the project once cited (built from pieces, so this file is clean)."""


def toml_examples(path: Path) -> list[tuple[str, str, str]]:
    """(kind, file name, text) of every TOML block of a README: "matrix", "thresholds" or "pyproject"."""
    examples = []
    for number, text in enumerate(TOML_BLOCK.findall(path.read_text(encoding="utf-8")), start=1):
        marker = EXAMPLE_NAME.search(text)
        document = tomllib.loads(text)  # every block is valid TOML, whatever it is
        if text.lstrip().startswith("# fragment"):  # part of a file, shown next to what completes it
            continue
        if marker:
            kind, name = marker.groups()
        elif "bound" in document:
            kind, name = "thresholds", f"thresholds_{number}.toml"
        elif "scenes" in document or "integrators" in document:
            kind, name = "matrix", f"matrix_{number}.toml"
        elif {"project", "tool", "build-system"} & set(document):
            kind, name = "pyproject", "pyproject.toml"
        else:
            raise AssertionError(f"{path.relative_to(ROOT)}: TOML block {number} is neither a matrix, a thresholds file "
                                 f"nor a pyproject.toml excerpt:\n{text}")
        examples.append((kind, name, text))
    return examples


def headings(path: Path) -> set[str]:
    """The section titles of a Markdown file, without the #s and backticks."""
    return {line.lstrip("#").strip().replace("`", "") for line in path.read_text(encoding="utf-8").splitlines()
            if line.startswith("#")}


def repository_files() -> list[Path]:
    """Every file of the repository: git's list where this is a checkout, else the files under the root."""
    git = shutil.which("git")
    if git and (ROOT / ".git").exists():
        listed = subprocess.run([git, "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
        return [ROOT / name for name in listed.decode().split("\0") if name and (ROOT / name).is_file()]
    skip = {".git", ".venv", "results", "__pycache__", ".pytest_cache"}
    return [path for path in ROOT.rglob("*")
            if path.is_file() and not skip & set(path.relative_to(ROOT).parts) and not path.name.endswith(".egg-info")]


@pytest.mark.parametrize("readme", PACKAGE_DOCS + (ROOT / "README.md",), ids=lambda path: str(path.relative_to(ROOT)))
def test_toml_examples_load_and_cheap_gates_pass(readme: Path, tmp_path: Path, fresh_reference_cache) -> None:
    examples = toml_examples(readme)
    for _, name, text in examples:
        (tmp_path / name).write_text(text, encoding="utf-8")
    matrices = {name: load_matrix(tmp_path / name) for kind, name, _ in examples if kind == "matrix"}
    for kind, name, _ in examples:
        if kind != "thresholds":
            continue
        thresholds = load_thresholds(tmp_path / name)
        matrix_name = thresholds.matrix_to_run()
        assert matrix_name is not None, f"{name}: a documented thresholds file should name the matrix it checks"
        matrix = load_matrix(matrix_name)
        validate_against(thresholds, planned_rows(matrix), what=f"the matrix of {name}")
        if all(scene.duration_s <= CHEAP_SCENE_S for scene in matrix.scenes):
            status = cli_main(["check", "--thresholds", str(tmp_path / name), "--db", str(tmp_path / "gate.sqlite"),
                               "--jobs", "1", "--no-progress"])
            assert status == 0, f"{readme.relative_to(ROOT)}: the documented gate {name} fails on its own matrix"
    assert all(matrix.runs for matrix in matrices.values())


def test_the_gate_reference_has_a_runnable_example() -> None:
    """bench/README.md documents at least one complete gate (matrix + thresholds) cheap enough to be run above."""
    examples = toml_examples(ROOT / "bench" / "README.md")
    kinds = [kind for kind, _, _ in examples]
    assert kinds.count("thresholds") >= 2 and kinds.count("matrix") >= 2


def test_relative_links_and_cited_paths_exist() -> None:
    missing = []
    for doc in DOCS + (ROOT / "bench" / "PERF.md",):
        text = doc.read_text(encoding="utf-8")
        # a recipe ("Adding a model") names the files the reader is about to create: not checked
        text = "".join(part for part in re.split(r"(?m)^(?=#+ )", text) if not re.match(r"#+ Adding ", part))
        for target in MARKDOWN_LINK.findall(text):
            if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                continue
            if not (doc.parent / target.split("#")[0]).exists():
                missing.append(f"{doc.relative_to(ROOT)}: link {target}")
        for span in CODE_SPAN.findall(text):
            path = span.rstrip(".,:;")
            if "/" not in path or not re.search(r"\.(py|toml|md|c|txt)$|/$", path) or PLACEHOLDER.search(path):
                continue
            bases = [base for base in (doc.parent, ROOT) if (base / path.split("/")[0]).exists()]
            if bases and not any(list(base.glob(path.rstrip("/"))) for base in bases):
                missing.append(f"{doc.relative_to(ROOT)}: path `{span}`")
    assert not missing, "\n".join(missing)


def test_every_cited_section_exists() -> None:
    """`models/README.md "Airy precession"` and the like, anywhere in the repository (code, tests, thresholds,
    generated text as docs/models/README.md), name a section that exists."""
    sections = {str(doc.relative_to(ROOT)): headings(doc) for doc in PACKAGE_DOCS}
    wrong, count = [], 0
    for path in repository_files():
        if path.suffix not in (".py", ".md", ".toml", ".txt", "") or path.name == "test_docs.py":
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        for match in CITATION.finditer(text):
            document = match.group(1).removeprefix("docs/")
            section = re.sub(r"\s*\n\s*(#\s*)?", " ", match.group(2) or match.group(3)).strip().replace("`", "")
            count += 1
            if not any(title == section or title.startswith((f"{section} (", f"{section}: "))
                       for title in sections[document]):
                wrong.append(f"{path.relative_to(ROOT)}: {document} has no section {section!r}")
    assert count > 50, f"only {count} citations found: the pattern no longer matches how the code cites"
    assert not wrong, "\n".join(wrong)


def test_nothing_cites_files_outside_the_repository() -> None:
    offenders = [f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
                 for path in repository_files() if path.name != "test_docs.py"
                 for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1)
                 if FORBIDDEN.search(line)]
    assert not offenders, "\n".join(offenders)


def test_readme_test_command_is_what_ci_runs() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    commands = [line for line in readme.splitlines() if "pytest" in line and line.startswith("python3 -m venv")]
    assert len(commands) == 1, "the README shows one install-and-test command"
    ci = [line for line in (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
          if "pytest" in line and not line.lstrip().startswith("#")]
    assert len(ci) == 1
    assert commands[0].endswith(ci[0].replace("--quiet ", "").strip()), (commands[0], ci[0])


def test_results_table_in_the_docs_is_the_schema() -> None:
    assert markdown_table() in (ROOT / "bench" / "README.md").read_text(encoding="utf-8")


def test_generated_documents_get_the_notes_they_cite(tmp_path: Path) -> None:
    written = copy_reference_docs(tmp_path)
    assert [path.relative_to(tmp_path).as_posix() for path in written] == [
        f"docs/{package}/README.md" for package in REFERENCE_DOCS]
    for path in written:
        source = ROOT / path.relative_to(tmp_path / "docs")
        assert path.read_text(encoding="utf-8") == source.read_text(encoding="utf-8")


# --- counts and lists: checked against the registry, the matrices and the model list -------------------------

NUMBER_WORDS = {"two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8, "nine": 9, "ten": 10}
MAIN_JOB = re.compile(r"The main job is every built-in integrator × (\d+) scenes")
DEFAULT_MATRIX_COUNTS = (
    (re.compile(r"default matrix's (\d+) integrators"), ("integrators",)),
    (re.compile(r"default matrix's results \((\d+) scenes"), ("scenes",)),
)
"""Other sentences that count what the default matrix holds (each checked wherever it appears)."""


def flowing_text(path: Path) -> str:
    """A document's text with line breaks inside paragraphs joined (a count may be split over two lines)."""
    return re.sub(r"[ \t]*\n[ \t]*(?=\S)", " ", path.read_text(encoding="utf-8"))


def markdown_rows(path: Path, header: str) -> list[list[str]]:
    """The cells of the rows of the table whose header line starts with ``header`` (backticks removed)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    start = next(number for number, line in enumerate(lines) if line.startswith(header))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip().replace("`", "") for cell in line.strip("|").split("|")])
    return rows


def default_matrix_counts() -> dict[str, int]:
    matrix = load_matrix("default")
    return {"runs": len(matrix.runs), "integrators": len({run.integrator for run in matrix.runs}),
            "scenes": len(matrix.scenes)}


def test_the_counts_of_the_default_matrix_in_the_docs_are_its_own() -> None:
    """"The main job is every built-in integrator × 9 scenes ...": true of the default matrix (its integrators are
    the registry's built-ins but the reference, so a new built-in integrator needs no count changed; a new scene
    fails here until the README says so). Counts given with a measurement ("measured when it was 1782 runs")
    record what was measured and are not the matrix's current size."""
    from foucault_bench.bench.problems.reference import REFERENCE_INTEGRATOR
    from foucault_bench.integrators import built_in_names

    actual = default_matrix_counts()
    swept = list(dict.fromkeys(run.integrator for run in load_matrix("default").runs))
    assert swept == [name for name in built_in_names() if name != REFERENCE_INTEGRATOR]
    main = MAIN_JOB.findall(flowing_text(ROOT / "README.md"))
    assert len(main) == 1, f"README.md: no sentence matching {MAIN_JOB.pattern!r} (the main job's size)"
    stated = [("README.md", {"scenes": int(main[0])})]
    for doc in DOCS:
        for pattern, names in DEFAULT_MATRIX_COUNTS:
            for found in pattern.findall(flowing_text(doc)):
                values = (found,) if isinstance(found, str) else found
                stated.append((str(doc.relative_to(ROOT)), dict(zip(names, map(int, values), strict=True))))
    wrong = [f"{doc}: {name} = {value}, the default matrix has {actual[name]}"
             for doc, counts in stated for name, value in counts.items() if value != actual[name]]
    assert not wrong, "\n".join(wrong)


def test_the_readme_scene_table_is_the_default_matrix() -> None:
    """README.md "The scenes": one row per scene of the default matrix, in its order, with the scene's model."""
    from foucault_bench.bench.problems.scenes import SCENES

    rows = markdown_rows(ROOT / "README.md", "| scene | pendulum | model |")
    listed = [(row[0], row[2]) for row in rows]
    expected = [(scene.name, SCENES[scene.name].model) for scene in load_matrix("default").scenes]
    assert listed == expected, f"README.md's scene table lists {listed}; the default matrix has {expected}"


def test_the_run_counts_of_the_built_in_matrices_in_bench_readme_are_their_own() -> None:
    """bench/README.md "Benchmark matrices": each built-in matrix's row states the number of runs it holds (a scene
    added to the halls or the ensembles fails here until the table says so). A matrix whose integrators are the
    registry's (``integrators = "built-in"``) grows with every new integrator without an edit (the integrator
    recipe's promise), so its row states the count at the measurement beside it, which only has to be a count."""
    import tomllib

    from foucault_bench.bench.run.matrix import built_in_matrices

    rows = markdown_rows(ROOT / "bench" / "README.md", "| matrix | what it is for | runs (when measured) |")
    stated = {row[0]: int(row[2]) for row in rows}
    assert set(stated) == set(built_in_matrices())
    explicit = [name for name in stated
                if tomllib.loads((ROOT / "bench" / "matrices" / f"{name}.toml").read_text(encoding="utf-8"))
                .get("integrators") != "built-in"]
    assert set(explicit) >= {"halls", "ensembles"}
    wrong = {name: (stated[name], len(load_matrix(name).runs)) for name in explicit
             if stated[name] != len(load_matrix(name).runs)}
    assert not wrong, f"bench/README.md states (runs, actual) {wrong}"


def test_the_real_halls_table_is_the_measurements() -> None:
    """models/README.md "Real halls": one row per ``[measurement.NAME]`` of bench/scenes/real_halls.toml, in the
    file's order, each citing that measurement's site and stating its rate and range."""
    import tomllib

    from foucault_bench.reports.halls import HALLS_FILE

    with open(HALLS_FILE, "rb") as handle:
        measurements = list(tomllib.load(handle)["measurement"].values())
    rows = markdown_rows(ROOT / "models" / "README.md", "| hall | L | latitude | measured |")
    assert len(rows) == len(measurements)
    for row, measured in zip(rows, measurements, strict=True):
        assert measured["source"].split("/")[0] in row[-1], (row[0], measured["source"])
        for figure in ("measured_deg_h", "low_deg_h", "high_deg_h"):
            assert f"{measured[figure]:g}" in row[3], (row[0], figure)


def test_the_number_of_models_in_the_docs_is_the_number_of_models() -> None:
    """Wherever a document counts the models ("seven models"), the count is the model list's: the READMEs avoid
    such counts (a new model then needs no edit), and this catches one written again."""
    from foucault_bench.models import MODELS

    stated = [(str(doc.relative_to(ROOT)), word) for doc in DOCS
              for word in re.findall(r"\b(\w+) models\b", flowing_text(doc), flags=re.I)
              if word.lower() in NUMBER_WORDS]
    wrong = [f"{doc}: '{word} models', there are {len(MODELS)} ({', '.join(MODELS)})"
             for doc, word in stated if NUMBER_WORDS[word.lower()] != len(MODELS)]
    assert not wrong, "\n".join(wrong)


def test_the_integrator_table_is_the_registry() -> None:
    """integrators/README.md "The integrators": a row for every built-in integrator and none other, with the
    family, order and stability limit each declares, and the stages of each fixed-step one (an adaptive one
    declares none: its row gives the stages of one attempt)."""
    from foucault_bench.integrators import REGISTRY, built_in_names

    rows = {name.strip(): row for row in markdown_rows(ROOT / "integrators" / "README.md", "| name | family |")
            for name in row[0].split(",")}
    missing, extra = set(built_in_names()) - set(rows), set(rows) - set(built_in_names())
    assert not missing and not extra, f"integrators/README.md's table: missing {sorted(missing)}, " \
                                      f"not registered {sorted(extra)}"
    wrong = []
    for name, (_, family, order, stages, limit, *_) in rows.items():
        integrator = REGISTRY[name]
        if family != integrator.family:
            wrong.append(f"{name}: family {family!r}, declared {integrator.family!r}")
        declared_order = "variable" if integrator.order is None else str(integrator.order)
        if order.split()[0].rstrip(",") != declared_order:
            wrong.append(f"{name}: order {order!r}, declared {integrator.order}")
        declared_stages = "–" if integrator.stages is None else str(integrator.stages)
        if not integrator.adaptive and stages.split()[0] != declared_stages:  # adaptive: stages per attempt
            wrong.append(f"{name}: stages {stages!r}, declared {integrator.stages}")
        declared_limit = integrator.stability_limit_kh
        numbers = [float(number) for number in re.findall(r"\d+(?:\.\d+)?", limit)]
        if declared_limit is not None and not any(math.isclose(number, declared_limit, rel_tol=5e-4)
                                                  for number in numbers):
            wrong.append(f"{name}: stability limit {limit!r}, declared {declared_limit:.4g}")
        if declared_limit is None and not integrator.adaptive and not limit.startswith("none"):
            wrong.append(f"{name}: stability limit {limit!r}, declared none")
    assert not wrong, "\n".join(wrong)


def test_the_scene_keys_in_bench_readme_are_the_reader_table() -> None:
    """bench/README.md "Scenes": the key table of a ``[scene.NAME]`` table is the one the reader reads
    (``SCENE_KEY_TABLE``: the scene's own keys and one per ``PendulumParameters`` field), each key explained."""
    from dataclasses import fields

    from foucault_bench.bench.problems.scene_reader import SCENE_KEY_TABLE, markdown_table
    from foucault_bench.models import PendulumParameters

    assert markdown_table() in (ROOT / "bench" / "README.md").read_text(encoding="utf-8")
    keys = [key.name for key in SCENE_KEY_TABLE]
    assert {field.name for field in fields(PendulumParameters)} <= set(keys) and len(set(keys)) == len(keys)
    unexplained = [key.name for key in SCENE_KEY_TABLE if len(key.meaning) < 10]
    assert not unexplained, f"scene keys without a meaning (a PendulumParameters field with neither a line in " \
                            f"its docstring's Attributes nor rule(..., meaning=...)?): {unexplained}"


def test_a_new_field_is_documented_by_its_rule_alone() -> None:
    """A field added with ``rule(..., meaning=...)`` and no line in the class docstring gets that meaning in the
    scene-key table (models/README.md "Adding a model": a new parameter is one line); the docstring's fields
    keep theirs."""
    from dataclasses import field, make_dataclass

    from foucault_bench.bench.problems.scene_reader import parameter_keys
    from foucault_bench.models import PendulumParameters
    from foucault_bench.models.parameters import rule

    meaning = "w, a steady horizontal force per unit mass along x (m/s²)"
    extended = make_dataclass("Extended", [("wind_accel_m_s2", float, field(default=0.0, metadata=rule(
        unit="m/s²", refinement=True, meaning=meaning)))], bases=(PendulumParameters,), frozen=True)
    extended.__doc__ = PendulumParameters.__doc__
    keys = {key.name: key.meaning for key in parameter_keys(extended)}
    assert keys["wind_accel_m_s2"] == meaning
    assert keys["length_m"].startswith("string length L (m)")


ADVISE_TRANSCRIPT = re.compile(r"```\n\$ foucault-bench advise --scene (\S+) --target (\S+)\n(.*?)```", re.S)
ADVISE_RUN = re.compile(r"^(?:recommended:|next:|) *(?P<integrator>\S+) (?P<setting>(?:tol|kh)=\S+): (?P<metric>\w+) "
                        r"(?P<error>\S+), (?P<kind>CPU|wall) time (?P<cost_ms>\S+) ms, (?P<nfev>\d+) "
                        r"(?P<counted>RHS evaluations|Taylor steps)(?: \((?P<ratio>\S+)× the cost\))?$")


def test_the_readme_advise_example_is_what_advise_prints() -> None:
    """README.md's ``advise`` transcript, re-rendered by ``bench.advise.render.render_text`` from the values it
    shows, is the same text: its format is today's, its physics key is the built-in scene's, the settings are
    ones the default matrix sweeps, the runs are in increasing cost, each ratio is its cost over the
    recommendation's (within the rounding of the printed costs), and every run shown meets the target. The
    numbers themselves come from a run of the default matrix and cannot be recomputed here."""
    from foucault_bench.bench.advise.answer import Advice
    from foucault_bench.bench.advise.render import TAYLOR_FAMILY, render_text
    from foucault_bench.bench.advise.target import parse_target
    from foucault_bench.bench.problems.scenes import SCENES
    from foucault_bench.bench.schema import setting_label
    from foucault_bench.integrators import get_integrator

    transcripts = ADVISE_TRANSCRIPT.findall((ROOT / "README.md").read_text(encoding="utf-8"))
    assert len(transcripts) == 1, "README.md: one `foucault-bench advise` transcript expected"
    scene_name, target_text, output = transcripts[0]
    target, problems = parse_target(target_text)
    assert target is not None, problems
    lines = output.rstrip("\n").splitlines()
    runs = [ADVISE_RUN.match(line) for line in lines[1:-2]]
    assert runs and all(runs), f"README.md: an advise line is not in today's format: {lines[1:-2]}"
    swept = {(run.integrator, setting_label(run.kh, run.tol)) for run in load_matrix("default").runs}
    records, ratios = [], []
    for match in runs:
        assert match is not None
        family = get_integrator(match["integrator"]).family
        assert (match["counted"] == "Taylor steps") == (family == TAYLOR_FAMILY), match.group(0)
        assert (match["integrator"], match["setting"]) in swept, f"not a run of the default matrix: {match.group(0)}"
        assert match["metric"] == target.metric and float(match["error"]) <= target.value, match.group(0)
        kind, value = match["setting"].split("=")
        records.append({"integrator": match["integrator"], kind: float(value), target.metric: float(match["error"]),
                        "cost_s": float(match["cost_ms"]) * 1e-3, "nfev": float(match["nfev"]), "family": family})
        ratios.append(float(match["ratio"]) if match["ratio"] else 1.0)
    costs = [record["cost_s"] for record in records]
    assert costs == sorted(costs), f"README.md: the advise example's runs are not in increasing cost: {costs}"
    for ratio, cost in zip(ratios, costs, strict=True):
        assert ratio == pytest.approx(cost / costs[0], rel=1e-2), (ratio, cost / costs[0])
    stored = re.fullmatch(rf"from (\d+) stored runs of {scene_name}; (\d+) meet the target", lines[-1])
    assert stored and int(stored[2]) <= int(stored[1]), lines[-1]
    assert lines[-2].startswith(f"model: {SCENES[scene_name].model} "), lines[-2]
    advice = Advice(scene=SCENES[scene_name], target=target, cost="cpu_time_s" if runs[0]["kind"] == "CPU"
                    else "wall_time_s", recommended=records[0], alternatives=records[1:],
                    model={"text": lines[-2].removeprefix("model: ")}, stored_runs=int(stored[1]),
                    meeting=int(stored[2]))
    without_ratios = [re.sub(r" \(\S+× the cost\)$", "", line) for line in lines]
    rendered = [re.sub(r" \(\S+× the cost\)$", "", line) for line in render_text(advice).splitlines()]
    assert rendered == without_ratios


def test_the_gate_columns_in_bench_readme_are_the_ones_the_gate_accepts() -> None:
    """bench/README.md "Columns: ..." names every column a bound may take (``VALUE_COLUMNS`` for ``max``, ``min``
    and ``max_abs``; ``MACHINE_COLUMNS`` only for ``max_ratio``) and no column the gate refuses."""
    from foucault_bench.bench.gate.thresholds import MACHINE_COLUMNS, VALUE_COLUMNS

    text = flowing_text(ROOT / "bench" / "README.md")
    paragraph = re.search(r"Columns: `max`, `min` and `max_abs` take (.*?) bounds, against", text, re.S)
    assert paragraph, "bench/README.md: the paragraph on the columns a bound may take is gone"
    deterministic, machine = paragraph[1].split("; `min_order`")
    named = set(CODE_SPAN.findall(deterministic))
    named |= {base + suffix for base in ("precession_rate_error", "precession_rate_ref_error")
              for suffix in ("_rad_s", "_earth") if "`_rad_s` and `_earth` forms" in deterministic}
    assert set(VALUE_COLUMNS) <= named, f"not named: {sorted(set(VALUE_COLUMNS) - named)}"
    assert set(CODE_SPAN.findall(machine)) == set(MACHINE_COLUMNS) | {"max_ratio"}


def test_reports_readme_has_a_row_for_every_module_of_reports() -> None:
    """reports/README.md "The modules": one row per module of ``reports/`` (``__init__.py`` aside), none for a module
    that is gone."""
    listed = {row[0] for row in markdown_rows(ROOT / "reports" / "README.md", "| module | job |")}
    modules = {path.name for path in (ROOT / "reports").glob("*.py") if path.name != "__init__.py"}
    assert listed == modules, f"missing: {sorted(modules - listed)}; gone: {sorted(listed - modules)}"
