"""Oracle tests of the report's tables and texts (reports.tables, reports.document, reports.build).

What the report shows is recomputed here from the database rows, independently of ``reports.tables``: the best
run of each family, the points each convergence fit used, the CPU-time columns of "All runs", the scenes table
of an inline scene, and the printed k·h of a setting. ``REPORT.md``, rendered by a CommonMark parser
(markdown-it-py), must hold the same tables, cell by cell, as ``index.html`` (read with the standard library's
``html.parser``), and texts from the data (messages, notes, plug-in family names, scene names from a database
made elsewhere) must come out of both renderings as themselves: no cell cut at a ``|``, no ``<…>`` swallowed as
a tag, no attribute or element injected into the page.
"""

from __future__ import annotations

import math
import json
import re
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import pandas as pd
import pytest
from markdown_it import MarkdownIt

from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.schema import setting_label
from foucault_bench.reports.build import ReportInputs, build_report
from foucault_bench.reports.document import Figure, Heading, Paragraph, Table, display_frame, format_value
from foucault_bench.reports.document import render_markdown
from foucault_bench.reports.html_page import render_html
from report_fixture import (
    DIVERGED_MESSAGE,
    FAILED_MESSAGE,
    FAILED_WITH_COST_MESSAGE,
    INLINE_SCENE,
    SCENE_NAMES,
    fixture_adequacy,
    report_html,
    report_pages,
)

INJECTION = "q' onmouseover='alert(5)' x='"
"""A scene name from a database made elsewhere that would add an attribute to an unescaped ``href='…'``."""
PLUGIN_FAMILY = "new <family> & co|x `tick` **star** back\\slash"
PLUGIN_MESSAGE = "<img src=x onerror=alert(1)> | broke & <b>stopped</b> `tick` **star**"
PLUGIN_INTEGRATOR = "plug_in_solver"
PROVENANCE = "made | elsewhere <x> & `y` **z**"

SAFE_ATTRIBUTES = {"lang", "charset", "id", "class", "href", "src", "alt", "type", "placeholder", "data-points",
                   "data-stem", "oninput", "colspan"}
"""Every attribute the report's own markup writes (``oninput`` only on the filter box of a folded table)."""
SAFE_ELEMENTS = {"html", "head", "meta", "title", "style", "script", "body", "h1", "h2", "h3", "nav", "ul", "li",
                 "a", "p", "strong", "em", "code", "figure", "img", "figcaption", "div", "table", "thead",
                 "tbody", "tr", "th", "td", "wbr", "details", "summary", "input", "span"}


# --------------------------------------------------------------------------------------------------------------
# reading the two renderings
# --------------------------------------------------------------------------------------------------------------
class Rendered(HTMLParser):
    """What a reader sees in an HTML document: its tables (title, header, rows, as text), headings,
    paragraphs outside figures, figure captions, and every element with its attributes."""

    CAPTURED = {"th", "td", "h1", "h2", "h3", "h4", "p", "figcaption", "strong", "summary"}

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.tables: list[tuple[str, list[list[str]]]] = []
        self.headings: list[str] = []
        self.paragraphs: list[str] = []
        self.captions: list[str] = []
        self.elements: list[tuple[str, list[tuple[str, str | None]]]] = []
        self.image_paragraphs = 0
        self._open: list[list] = []  # [tag, text pieces, holds an image]
        self._figures = 0
        self._last_strong = ""
        self._row: list[str] | None = None
        self._details = False  # in a table's folded row (``Table.details``)
        self._summary = ""
        self.feed(text)
        self.close()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.elements.append((tag, attrs))
        if tag == "figure":
            self._figures += 1
        elif tag == "table":
            self.tables.append((self._last_strong, []))
        elif tag == "tr":
            self._row = []
            self._details = "details" in (dict(attrs).get("class") or "").split()
        elif tag == "img":
            for entry in self._open:
                entry[2] = True
        if tag in self.CAPTURED:
            self._open.append([tag, [], False])

    def handle_endtag(self, tag: str) -> None:
        if tag == "figure":
            self._figures -= 1
        elif tag == "tr" and self._row is not None and self._details:
            rows = self.tables[-1][1]  # a folded row: its text is the last column of the row above it
            rows[-1].extend(self._row)
            if len(rows[0]) < len(rows[-1]):
                rows[0].append(self._summary)
            self._row, self._details = None, False
        elif tag == "tr" and self._row is not None:
            self.tables[-1][1].append(self._row)
            self._row = None
        if tag not in self.CAPTURED:
            return
        opened, pieces, image = self._open.pop()
        assert opened == tag, (opened, tag)
        text = " ".join("".join(pieces).split())
        if tag in ("th", "td"):
            self._row.append(text.removeprefix(self._summary).lstrip() if self._details else text)
        elif tag.startswith("h"):
            self.headings.append(text)
        elif tag == "strong":
            self._last_strong = text
        elif tag == "figcaption":
            self.captions.append(text)
        elif tag == "summary":
            self._summary = text
        elif tag == "p" and self._figures == 0:
            if image:
                self.image_paragraphs += 1
            else:
                self.paragraphs.append(text)

    def handle_data(self, data: str) -> None:
        for entry in self._open:
            entry[1].append(data)

    def table(self, title: str) -> pd.DataFrame:
        """The table titled ``title`` as text cells (first row: the header)."""
        matches = [rows for found, rows in self.tables if found == title]
        assert len(matches) == 1, (title, [found for found, _ in self.tables])
        header, *rows = matches[0]
        return pd.DataFrame(rows, columns=header)

    def links(self) -> list[str]:
        """Every href and src (fragments excluded)."""
        return [value for _, attrs in self.elements for name, value in attrs
                if name in ("href", "src") and value and not value.startswith("#")]


def _markdown_as_html(markdown: str) -> str:
    return MarkdownIt("commonmark").enable("table").render(markdown)


def _renderings(folder: Path) -> tuple[Rendered, Rendered]:
    page = Rendered(report_html(folder))
    markdown = Rendered(_markdown_as_html((folder / "REPORT.md").read_text(encoding="utf-8")))
    return page, markdown


def _database_rows(database: Path) -> pd.DataFrame:
    with ResultsStore(database, create=False) as store:
        return store.frame()


def _number(cell: str) -> float:
    return math.nan if cell == "–" else float(cell)


def _figure_paragraph(text: str) -> bool:
    return text.endswith("(SVG)")


# --------------------------------------------------------------------------------------------------------------
# a second report: a scene name and a plug-in family that would inject markup
# --------------------------------------------------------------------------------------------------------------
def _awkward_runs(database: Path) -> pd.DataFrame:
    """The fixture's seed_2min rows renamed to ``INJECTION``, plus a plug-in family whose two runs failed (no
    usable run) with a message full of markup."""
    runs = _database_rows(database)
    scene = runs[runs["scene"] == "seed_2min"].copy()
    scene["scene"] = INJECTION
    failed = scene[scene["integrator"] == "scipy_lsoda"].head(2).copy()
    failed = failed.assign(integrator=PLUGIN_INTEGRATOR, family=PLUGIN_FAMILY, status="failed",
                           message=PLUGIN_MESSAGE, reference_error=np.nan, cpu_time_s=np.nan,
                           cpu_time_spread_s=np.nan, wall_time_s=np.nan, declared_order=None,
                           run_key=[f"plug-in-{index}" for index in range(2)])
    return pd.concat([scene, failed], ignore_index=True)


@pytest.fixture(scope="module")
def awkward_report(fixture_database: Path, tmp_path_factory) -> tuple[Path, pd.DataFrame]:
    runs = _awkward_runs(fixture_database)
    folder = tmp_path_factory.mktemp("awkward-report")
    build_report(ReportInputs(runs=runs, interactive=False,
                              provenance={"database": PROVENANCE}), folder)
    return folder, runs


# --------------------------------------------------------------------------------------------------------------
# the two renderings agree
# --------------------------------------------------------------------------------------------------------------
def test_report_md_tables_equal_index_html_tables_cell_by_cell(fixture_report: Path) -> None:
    page, markdown = _renderings(fixture_report)
    assert len(page.tables) == len(markdown.tables) >= 8
    for (page_title, page_rows), (markdown_title, markdown_rows) in zip(page.tables, markdown.tables, strict=True):
        assert page_title == markdown_title
        assert len(page_rows) == len(markdown_rows) > 1, page_title
        for page_row, markdown_row in zip(page_rows, markdown_rows, strict=True):
            assert page_row == markdown_row, page_title
    assert [heading for index, heading in enumerate(page.headings)
            if index == 0 or heading != page.headings[0]] == markdown.headings  # each page repeats the title
    assert page.paragraphs == [text for text in markdown.paragraphs if not _figure_paragraph(text)]
    captions = [text.rsplit(" (", 1)[0] for text in page.captions]
    assert captions == [text.rsplit(" (", 1)[0] for text in markdown.paragraphs if _figure_paragraph(text)]
    assert markdown.image_paragraphs == len(page.captions)


def test_texts_with_pipes_tags_and_ampersands_survive_both_renderings(fixture_report: Path) -> None:
    page, markdown = _renderings(fixture_report)
    notes = [row["note"] for rows in fixture_adequacy().values() for row in rows]
    for rendered in (page, markdown):
        cells = {cell for _, rows in rendered.tables for row in rows for cell in row}
        for text in (DIVERGED_MESSAGE, FAILED_MESSAGE, FAILED_WITH_COST_MESSAGE, *notes):
            assert text in cells, text
        assert any("clicking 'all <family>' hides the family" in text for text in rendered.paragraphs)


def test_text_from_the_data_is_never_markup(awkward_report: tuple[Path, pd.DataFrame]) -> None:
    """A scene name that closes an attribute, a plug-in family and message holding tags: no element or
    attribute comes from them in index.html or in REPORT.md, every link names a file of the report, and the
    texts read as they are stored."""
    folder, _ = awkward_report
    page, markdown = _renderings(folder)
    for rendered, elements in ((page, SAFE_ELEMENTS), (markdown, SAFE_ELEMENTS - {"script", "input", "style"})):
        assert {tag for tag, _ in rendered.elements} <= elements
        attributes = {(tag, name) for tag, attrs in rendered.elements for name, _ in attrs}
        aligned = {(tag, "style") for tag in ("th", "td")}  # markdown-it aligns table columns with a style
        assert {name for _, name in attributes - aligned} <= SAFE_ATTRIBUTES
        assert {tag for tag, name in attributes if name == "oninput"} <= {"input"}
        links = rendered.links()
        assert any(INJECTION in unquote(link) for link in links)
        for link in links:
            assert (folder / unquote(link)).is_file(), link
        assert f"Scene {INJECTION}" in rendered.headings
        cells = {cell for _, rows in rendered.tables for row in rows for cell in row}
        assert {PLUGIN_FAMILY, PLUGIN_MESSAGE, INJECTION} <= cells
        assert any(f"Family {PLUGIN_FAMILY}: {PLUGIN_INTEGRATOR}" in text for text in rendered.paragraphs)
        assert f"database: {PROVENANCE}" in rendered.paragraphs


def test_an_interactive_chart_cannot_end_its_script_or_leave_its_attributes() -> None:
    """The plotly JSON of a chart is data inside a script: a title holding ``</script>`` stays in it; the
    chart's file links, from a scene name, stay inside their attributes."""
    stem = f"figures/work_precision_{INJECTION}_reference_error"
    title = "</script><script>alert(1)</script><!--"
    blocks = [Heading("Work-precision"), Figure(stem, f"{INJECTION}: caption", f'{{"layout": {{"title": "{title}"}}}}', 3)]
    html_text = render_html("t", blocks)
    page = Rendered(html_text)
    scripts = [attrs for tag, attrs in page.elements if tag == "script"]
    assert len(scripts) == 3  # plotly.js, the legend helper, the chart
    assert {name for _, attrs in page.elements for name, _ in attrs} <= SAFE_ATTRIBUTES
    assert sorted(unquote(link) for link in page.links() if link != "plotly.min.js") == [
        f"{stem}.png", f"{stem}.svg"]
    chart = html_text.split("var figure = ", 1)[1].split("; Plotly.newPlot", 1)[0]
    import json

    assert json.loads(chart)["layout"]["title"] == title


def test_markdown_escapes_only_what_markdown_would_read() -> None:
    """Markdown of ordinary texts stays readable: intraword underscores, words and numbers are left alone; a
    paragraph that starts like a list stays a paragraph."""
    blocks = [Paragraph("- 1. reference_error at kh=0.2726 for Ω_E|sin φ| _x_ *y*"),
              Paragraph("3. `a|b <c>` and **bold & <i>**")]
    markdown = render_markdown("t", blocks)
    assert "reference_error at kh=0.2726" in markdown
    rendered = Rendered(_markdown_as_html(markdown))
    assert rendered.paragraphs == ["- 1. reference_error at kh=0.2726 for Ω_E|sin φ| _x_ *y*",
                                   "3. a|b <c> and bold & <i>"]
    assert {tag for tag, _ in rendered.elements} == {"h1", "p", "code", "strong"}
    assert Rendered(render_html("t", blocks)).paragraphs == rendered.paragraphs


# --------------------------------------------------------------------------------------------------------------
# table contents recomputed from the rows
# --------------------------------------------------------------------------------------------------------------
BEST_OF_FAMILY = "Best run of each family per scene (reference error)"


def _usable(rows: pd.DataFrame) -> pd.DataFrame:
    """Runs a decision may use: ok, finite reference error, finite CPU time > 0."""
    error, cost = rows["reference_error"].abs(), rows["cpu_time_s"]
    return rows[(rows["status"] == "ok") & np.isfinite(error) & np.isfinite(cost) & (cost > 0)]


def _check_best_of_family(page: Rendered, runs: pd.DataFrame) -> int:
    """The best-of-family table has one row per (scene, family) present, holding that family's most accurate
    usable run, or 'no usable run' with its status counts; returns how many families had none."""
    table = page.table(BEST_OF_FAMILY)
    assert sorted(zip(table["scene"], table["family"], strict=True)) == sorted(
        set(zip(runs["scene"], runs["family"], strict=True)))
    none_usable = 0
    for row in table.itertuples(index=False):
        group = runs[(runs["scene"] == row.scene) & (runs["family"] == row.family)]
        usable = _usable(group)
        if usable.empty:
            counts = group["status"].value_counts()
            expected = ", ".join(f"{counts[status]} {status}" for status in ("ok", "diverged", "failed", "timeout")
                                 if status in counts)
            assert (row.outcome, row.integrator, row.error) == (f"no usable run ({expected})", "", "–")
            none_usable += 1
            continue
        errors = usable["reference_error"].abs()
        best = usable[errors == errors.min()].sort_values("cpu_time_s").iloc[0]
        assert (row.outcome, row.integrator) == ("best run", best["integrator"])
        assert row.setting == setting_label(best["kh"], best["tol"])
        assert _number(row.error) == pytest.approx(abs(best["reference_error"]), rel=5e-3)
    return none_usable


def test_best_of_family_has_a_row_per_family_present(fixture_report: Path, fixture_database: Path,
                                                     awkward_report: tuple[Path, pd.DataFrame]) -> None:
    page, _ = _renderings(fixture_report)
    assert _check_best_of_family(page, _database_rows(fixture_database)) == 0
    folder, runs = awkward_report
    page, _ = _renderings(folder)
    assert _check_best_of_family(page, runs) == 1  # the plug-in family: both runs failed


def _least_squares_slope(log_h: np.ndarray, log_e: np.ndarray) -> float:
    return float(np.polyfit(log_h, log_e, 1)[0])


def test_convergence_points_are_the_points_fitted(fixture_report: Path, fixture_database: Path) -> None:
    """Per fixed-step integrator and scene: ``points`` distinct steps of the usable runs (ok, error finite,
    positive and ≤ 0.1, where it has not saturated) are consecutive in the sweep and their least-squares slope
    is the fitted order, printed with two decimals as in the charts' legends; no points, no order."""
    runs = _database_rows(fixture_database)
    shown = Rendered(report_html(fixture_report)).table(
        "Observed and declared orders of convergence")
    full = pd.read_csv(fixture_report / "tables" / "convergence_orders.csv").set_index(["scene", "integrator"])
    checked = {"fitted": 0, "none": 0}
    for row in shown[shown["kind"] == "fixed-step"].itertuples(index=False):
        group = runs[(runs["scene"] == row.scene) & (runs["integrator"] == row.integrator)]
        error = group["reference_error"]
        usable = group[(group["status"] == "ok") & np.isfinite(error) & (error > 0) & (error <= 0.1)]
        steps = usable.groupby("step_s")["reference_error"].apply(lambda e: np.exp(np.log(e).mean())).sort_index()
        points, fitted = int(row.points), full.loc[(row.scene, row.integrator), "fitted_order"]
        assert points <= len(steps)
        if points == 0:
            assert row.fitted_order == "–" and math.isnan(fitted)
            checked["none"] += 1
            continue
        log_h, log_e = np.log(steps.index.to_numpy(float)), np.log(steps.to_numpy(float))
        slopes = [_least_squares_slope(log_h[start:start + points], log_e[start:start + points])
                  for start in range(len(steps) - points + 1)]
        assert any(slope == pytest.approx(fitted, rel=1e-9) for slope in slopes), (row.scene, row.integrator)
        assert row.fitted_order == f"{fitted:.2f}"
        checked["fitted"] += 1
    assert checked["fitted"] > 0 and checked["none"] > 0  # explicit Euler on pantheon: every error saturated


def test_all_runs_shows_cpu_time_and_its_spread(fixture_report: Path, fixture_database: Path) -> None:
    runs = _database_rows(fixture_database)
    shown = Rendered(report_html(fixture_report)).table("All runs (main columns)")
    assert len(shown) == len(runs)
    keyed = {(row.scene, row.integrator, setting_label(row.kh, row.tol)): row for row in runs.itertuples()}
    for row in shown.itertuples(index=False):
        setting = f"tol={float(row.tol):g}" if row.tol != "–" else f"kh={row.kh}"
        stored = keyed[(row.scene, row.integrator, setting)]
        for column in ("cpu_time_s", "cpu_time_spread_s", "wall_time_s"):
            value = getattr(stored, column)
            if value is None or math.isnan(value):
                assert getattr(row, column) == "–"
            else:
                assert _number(getattr(row, column)) == pytest.approx(value, rel=5e-3), column


def test_a_setting_quoted_in_a_summary_is_found_in_the_tables(fixture_report: Path) -> None:
    """kh has the digits of ``bench.schema.setting_label`` in every table: each ``kh=…`` setting of the
    summaries is a kh cell of the same scene and integrator in "All runs"."""
    page = Rendered(report_html(fixture_report))
    runs = page.table("All runs (main columns)")
    kh_cells = set(zip(runs["scene"], runs["integrator"], runs["kh"], strict=True))
    quoted = 0
    for title, rows in page.tables:
        header = rows[0]
        for cells in rows[1:]:
            row = dict(zip(header, cells, strict=True))
            for column in ("setting", "runner_up_setting"):
                if row.get(column, "").startswith("kh="):
                    integrator = row["runner_up"] if column == "runner_up_setting" else row["integrator"]
                    assert (row["scene"], integrator, row[column].removeprefix("kh=")) in kh_cells, (title, row)
                    quoted += 1
    assert quoted > 0


def test_the_scenes_table_fills_an_inline_scene_from_its_rows(fixture_report: Path,
                                                               fixture_database: Path) -> None:
    runs = _database_rows(fixture_database)
    scenes = Rendered(report_html(fixture_report)).table(
        "The scenes: place, pendulum, release, grid, model and why").set_index("scene")
    assert sorted(scenes.index) == sorted(runs["scene"].unique())
    for scene, rows in runs.groupby("scene"):
        shown = scenes.loc[scene]
        assert shown["model"] == rows["model"].iloc[0] and rows["model"].nunique() == 1
        assert _number(shown["duration_s"]) == rows["duration_s"].iloc[0]
        assert "e" not in shown["duration_s"]  # 3600 s, not 3.6e+03
        interval = rows["duration_s"].iloc[0] / (rows["n_out"].iloc[0] - 1)
        assert _number(shown["output_interval_s"]) == pytest.approx(interval, rel=5e-3)
    assert "inline scene" in scenes.loc[INLINE_SCENE, "place"]


@pytest.mark.parametrize(("value", "spec", "text"), [
    (3600.0, None, "3600"), (86164.0905, None, "86164"), (123.456, None, "123"), (0.0012345, None, "0.00123"),
    (2.5e7, None, "2.5e+07"), (0.27259, ".4g", "0.2726"), (6.0012, ".2f", "6.00"), (float("nan"), None, "–"),
    ("two\nlines", None, "two lines"),
])
def test_numbers_are_printed_as_the_readme_says(value: object, spec: str | None, text: str) -> None:
    assert format_value(value, spec) == text


def test_a_table_cell_never_splits_a_markdown_row() -> None:
    frame = pd.DataFrame({"scene": ["a|b", "c"], "note": ["line one\nline two | <i>x</i> & y", "`q`"]})
    shown = display_frame(frame)
    markdown = render_markdown("t", [Table("t", shown, "tables/t")])
    rendered = Rendered(_markdown_as_html(markdown)).table("t")
    assert rendered.values.tolist() == [["a|b", "line one line two | <i>x</i> & y"], ["c", "`q`"]]


# --------------------------------------------------------------------------------------------------------------
# the notes describe what exists
# --------------------------------------------------------------------------------------------------------------
def test_the_reports_readme_describes_what_exists() -> None:
    """reports/README.md (copied into every report's docs/) names no section or function that does not exist,
    the cost the decisions use, and the studies' sizes as the code sets them."""
    from foucault_bench.reports import tables
    from foucault_bench.bench.studies import (
        LongTimeEnergyConfig,
        PrecessionLatitudeConfig,
        ReleaseAzimuthConfig,
        StabilitySweepConfig,
        family_representatives,
    )

    text = (Path(tables.__file__).parent / "README.md").read_text(encoding="utf-8")
    flat = " ".join(text.split())
    assert "shootout" not in text.lower() and "least median wall time" not in text
    assert "against CPU time and against accepted steps" in flat
    for function in re.findall(r"`reports\.tables\.(\w+)`", text):
        assert hasattr(tables, function), function
    stability = StabilitySweepConfig()
    # the integrators are the registry's (no count to restate: a new fixed-step integrator needs no edit here)
    assert f"runs of {stability.steps} steps (every fixed-step integrator × {len(stability.kh)} values of k·h" in flat
    long_time = LongTimeEnergyConfig()
    long_time_runs = len(long_time.runs) if long_time.runs is not None else len(family_representatives())
    assert f"{long_time_runs} runs of {long_time.duration_s / 3600:g} h" in flat
    assert f"over {long_time.duration_s / 3600:g} h of the Panthéon" in flat
    latitudes = PrecessionLatitudeConfig().n_latitudes
    assert f"all {latitudes} latitudes" in flat and f"at {latitudes} latitudes" in flat
    azimuth = ReleaseAzimuthConfig()
    cases = len(azimuth.azimuths_deg) * len(azimuth.latitudes_deg)
    assert (f"runs of {azimuth.duration_s / 60:g} min (every fixed-step integrator with a volume-preserving map × "
            f"{len(azimuth.azimuths_deg)} azimuths × {len(azimuth.latitudes_deg)} latitudes) against {cases} heyoka "
            "references") in flat
    assert f"at {len(azimuth.azimuths_deg)} azimuths at {len(azimuth.latitudes_deg)} latitudes" in flat


def test_the_convergence_notes_say_what_was_fitted() -> None:
    from foucault_bench.reports.tables import COLUMN_NOTES

    assert "over the ok runs" not in COLUMN_NOTES["fitted_order"] and "saturated" in COLUMN_NOTES["fitted_order"]
    assert "used" in COLUMN_NOTES["points"]


def test_each_scene_page_shows_that_scene_s_rows_only(fixture_report: Path, fixture_database: Path) -> None:
    """Each scene's page, read alone: its runs table holds exactly the database's rows of that scene (status,
    message with its ``|``, ``<`` and ``&``, reference error and CPU time as stored), and every chart on it is
    that scene's, naming in its hover data only runs of that scene."""
    runs = _database_rows(fixture_database)
    pages = {page.name: page for page in report_pages(fixture_report)}
    checked = {"rows": 0, "not ok": 0, "charts": 0}
    for scene, rows in runs.groupby("scene"):
        page = pages[f"scene_{scene}.html"]  # the fixture's scene names are their own file stems
        text = page.read_text(encoding="utf-8")
        shown = Rendered(text).table(f"{scene}: its runs (main columns)")
        assert set(shown["scene"]) == {scene} and len(shown) == len(rows)
        stored = {(row.integrator, setting_label(row.kh, row.tol)): row for row in rows.itertuples()}
        for row in shown.itertuples(index=False):
            run = stored.pop((row.integrator, f"tol={float(row.tol):g}" if row.tol != "–" else f"kh={row.kh}"))
            assert row.status == run.status
            assert row.message == ("–" if run.message is None else " ".join(str(run.message).split()))
            for column in ("reference_error", "cpu_time_s"):
                value = getattr(run, column)
                assert (getattr(row, column) == "–" if value is None or math.isnan(value)
                        else _number(getattr(row, column)) == pytest.approx(value, rel=5e-3)), column
            checked["rows"] += 1
            checked["not ok"] += row.status != "ok"
        assert not stored  # every stored run of the scene is shown
        settings = {(row.integrator, setting_label(row.kh, row.tol)) for row in rows.itertuples()}
        for chart in re.findall(r"var figure = (.*?); Plotly\.newPlot", text, re.S):
            figure = json.loads(chart)
            assert figure["layout"]["title"]["text"].startswith(f"{scene}:")
            named = {(hover[0], hover[2]) for trace in figure["data"] for hover in trace.get("customdata") or []}
            assert named and named <= settings
            checked["charts"] += 1
    assert checked["rows"] == len(runs) and checked["not ok"] > 0 and checked["charts"] >= 4 * len(SCENE_NAMES)


RANKED = "Every integrator at matched accuracy: rank and cost ratio per scene and target"


def test_every_integrator_is_ranked_at_each_target_as_the_rows_say(fixture_report: Path,
                                                                    fixture_database: Path) -> None:
    """Per scene and target: each integrator of the scene that has a usable run meeting the target appears once,
    ranked by the CPU time of its cheapest such run (rank 1 the cheapest), with that run's setting, error and
    cost over the cheapest integrator's; every other integrator of the scene is 'not reached' with the smallest
    error of its usable runs."""
    runs = _database_rows(fixture_database)
    shown = Rendered(report_html(fixture_report)).table(RANKED)
    checked = {"reached": 0, "not reached": 0}
    for (scene, target_cell), rows in shown.groupby(["scene", "target"], sort=False):
        target = float(target_cell)
        scene_runs = runs[runs["scene"] == scene]
        usable = _usable(scene_runs).assign(error=lambda frame: frame["reference_error"].abs())
        met = usable[usable["error"] <= target].sort_values(["cpu_time_s", "error"], kind="stable")
        cheapest = met.drop_duplicates("integrator")
        assert list(rows["integrator"]) == [*cheapest["integrator"],
                                            *sorted(set(scene_runs["integrator"]) - set(cheapest["integrator"]))]
        for rank, (row, run) in enumerate(zip(rows.head(len(cheapest)).itertuples(index=False),
                                              cheapest.itertuples(index=False), strict=True), start=1):
            assert (int(row.rank), row.outcome, row.setting) == (rank, "reached", setting_label(run.kh, run.tol))
            assert _number(row.cpu_time_s) == pytest.approx(run.cpu_time_s, rel=5e-3)
            assert _number(row.ratio) == pytest.approx(run.cpu_time_s / cheapest["cpu_time_s"].iloc[0], rel=5e-3)
            checked["reached"] += 1
        for row in rows.iloc[len(cheapest):].itertuples(index=False):
            own = usable[usable["integrator"] == row.integrator]["error"]
            assert (row.outcome, row.rank) == ("not reached", "–")
            if own.empty:
                assert row.best_error == "–"
            else:
                assert _number(row.best_error) == pytest.approx(own.min(), rel=5e-3)
            checked["not reached"] += 1
    assert checked["reached"] > 0 and checked["not reached"] > 0
