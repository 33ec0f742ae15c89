"""Table files and page parts of the report (reports.latex, reports.document, reports.build): the LaTeX is
pure ASCII and, where pdflatex exists, compiles with no line wider than the page; the HTML right-aligns numbers
and wraps text; the long "All runs" table folds and filters; the figure counter knows its total."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from foucault_bench.reports import tables
from foucault_bench.reports.builder import Builder
from foucault_bench.reports.document import (
    Table,
    display_frame,
    html_table,
    numeric_columns,
    render_markdown,
    write_table_files,
)
from foucault_bench.reports.html_page import render_html
from foucault_bench.reports.latex import latex_table, latex_text
from test_reports import adequacy_fixture, results_fixture

AWKWARD = pd.DataFrame({
    "scene": ["lab_3m", "pantheon"], "integrator": ["rk4", "heyoka_taylor"], "kh": [0.1, float("nan")],
    "rate_rad_s": [-5.48e-5, 1.0 / 3.0], "ok": [3.0, 12.0],
    "note": ["reached ≤ 1e-6 at kh = 0.1 – cheapest; θ₀ = A/L, ψ₀ − ω sin φ·t, (kh)²/4, 2√2, 50 % & $5 #1 ~x^y {a} "
             "back\\slash <less> |abs| “quoted” … ▲ ✕ ▽ Ω_E, café, Α", "–"],
})


def _report_tables() -> dict[str, pd.DataFrame]:
    runs = results_fixture()
    return {"matched_accuracy": tables.matched_accuracy(runs), "per_integrator": tables.per_integrator(runs),
            "fronts": tables.fronts(runs), "families": tables.families(runs),
            "convergence_orders": tables.convergence_orders(runs), "runs_compact": tables.compact_table(runs),
            "runs_full": tables.full_table(runs), "model_adequacy": adequacy_fixture(), "awkward": AWKWARD}


@pytest.fixture(scope="module")
def table_folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("tables")
    for name, frame in _report_tables().items():
        write_table_files(frame, folder, name, f"{name}: reference error ≤ 1e-3 – θ₀ and Ω_E", tables.COLUMN_FORMATS)
    return folder


@pytest.mark.parametrize(("text", "latex"), [
    ("≤ 1e-3 – ok", r"$\le$ 1e-3 -- ok"),
    ("θ₀ = A/L", r"$\theta_{0}$ = A/L"),
    ("(kh)²/4", "(kh)$^{2}$/4"),
    ("Ω_E", r"$\Omega$\_\allowbreak{}E"),
    ("−ω sin φ", r"$-\omega$ sin $\phi$"),
    ("50 % & $5", r"50 \% \& \$5"),
    ("a<b", "a$<$b"),
    ("café Α", "cafe A"),
])
def test_latex_text(text: str, latex: str) -> None:
    assert latex_text(text) == latex


def test_latex_tables_are_pure_ascii(table_folder: Path) -> None:
    for path in table_folder.glob("*.tex"):
        text = path.read_bytes()
        assert text.isascii(), path.name
        assert b"\\begin{longtable}" in text and b"\\begin{tabular}" not in text


def test_a_wide_table_is_split_into_parts_that_repeat_the_row_names() -> None:
    shown = display_frame(tables.full_table(results_fixture()))
    text = latex_table(shown, "All runs", numeric_columns(shown))
    parts = text.count("\\begin{longtable}")
    assert parts > 1 and text.count(f"of {parts})") == parts
    headers = [line for line in text.splitlines() if line.endswith(r"\\ \hline")][::2]  # first-page headers
    assert len(headers) == parts and all(header.startswith(r"scene & integrator & kh") for header in headers)
    covered = {cell.strip() for header in headers for cell in header.removesuffix(r" \\ \hline").split("&")}
    assert covered == {latex_text(column) for column in shown.columns}  # every column in some part


@pytest.mark.skipif(shutil.which("pdflatex") is None, reason="no pdflatex on this machine")
def test_latex_tables_compile_and_fit_the_page(table_folder: Path, tmp_path: Path) -> None:
    for path in sorted(table_folder.glob("*.tex")):
        document = tmp_path / f"doc_{path.stem}.tex"
        document.write_text("\\documentclass{article}\n\\usepackage{longtable,array}\n\\begin{document}\n"
                            f"\\input{{{path.as_posix()}}}\n\\end{{document}}\n", encoding="ascii")
        result = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", document.name],
                                cwd=tmp_path, capture_output=True, text=True, timeout=120, check=False)
        log = (tmp_path / f"doc_{path.stem}.log").read_text(encoding="latin-1")
        assert result.returncode == 0, (path.name, log[-2000:])
        assert (tmp_path / f"doc_{path.stem}.pdf").stat().st_size > 0
        assert "Overfull \\hbox" not in log, (path.name, re.findall(r"Overfull \\hbox.*", log))


def test_html_right_aligns_numbers_and_wraps_text() -> None:
    shown = display_frame(AWKWARD)
    assert numeric_columns(shown) == {"kh", "rate_rad_s", "ok"}
    table = html_table(shown)
    assert "<th class='num'>kh</th>" in table and "<th class='text'>note</th>" in table
    assert "<th class='num'>rate_<wbr>rad_<wbr>s</th>" in table
    assert "<td class='num'>–</td>" in table and "<td class='text'>pantheon</td>" in table
    page = render_html("t", [Table("t", shown, "tables/t")])
    style = page.split("<style>")[1].split("</style>")[0]
    assert re.search(r"\.num \{[^}]*text-align: right", style)
    text_rule = re.search(r"\.text \{([^}]*)\}", style).group(1)
    assert "nowrap" not in text_rule and "max-width" in text_rule
    assert "nowrap" not in style.replace(re.search(r"\.num \{[^}]*\}", style).group(0), "")


def test_the_all_runs_table_folds_and_filters() -> None:
    shown = display_frame(tables.compact_table(results_fixture()))
    blocks = [Table("All runs", shown, "tables/runs_compact", collapsible=True), Table("Small", shown.head(2), "s")]
    page = render_html("t", blocks)
    assert page.count("<details class='long-table'>") == 1 and f"show the {len(shown)} rows" in page
    assert "oninput='filterRows(this)'" in page and "function filterRows(input)" in page
    assert "<script src" not in page  # nothing fetched
    assert "<details><summary>" in render_markdown("t", blocks)
    assert "function filterRows" not in render_html("t", blocks[1:])


def test_the_figure_counter_shows_a_total(tmp_path: Path, capsys) -> None:
    builder = Builder(tmp_path, progress=True, interactive=False)
    drawn = []
    for name in ("a", "b", "c"):
        builder.figure(name, f"figure {name}", lambda stem: drawn.append(stem.name) or stem)
    assert drawn == []  # counted first, drawn after
    builder.draw_figures()
    assert drawn == ["a", "b", "c"]
    assert "| 0/3 [" in capsys.readouterr().err  # the total is known before the first figure is drawn


@pytest.mark.skipif(shutil.which("chromium") is None, reason="no headless chromium on this machine")
def test_the_row_filter_runs_in_a_browser(tmp_path: Path) -> None:
    """Type two words in the filter of the folded table: only the rows holding both stay shown."""
    shown = display_frame(tables.compact_table(results_fixture()))
    typed = ("<script>var box = document.querySelector('details input'); box.value = 'pantheon rk4'; "
             "filterRows(box);</script></body>")
    page = tmp_path / "page.html"
    page.write_text(render_html("t", [Table("All runs", shown, "r", collapsible=True)]).replace("</body>", typed),
                    encoding="utf-8")
    dom = subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu",
                          f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=120, check=False).stdout
    rows = re.findall(r"<tr( style=\"display: none;\")?>(.*?)</tr>", dom.split("<tbody>")[1])
    kept = [cells for hidden, cells in rows if not hidden]
    expected = shown[(shown["scene"] == "pantheon") & (shown["integrator"] == "rk4")]
    assert len(rows) == len(shown) and len(kept) == len(expected) > 0
    assert f"{len(expected)} of {len(shown)} rows" in dom
