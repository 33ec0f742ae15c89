"""``foucault-bench report``: build the report folder (index.html, a page per scene, the studies and all runs,
REPORT.md, figures, tables) from results.

    foucault-bench report [--db PATH] [--matrix-id ID] [--out DIR] [--force] [--studies {stored,recompute,skip}]
                          [--targets ERROR ...] [--static] [--jobs N]

The folder opens in a browser with no server and no network: the HTML pages and REPORT.md hold the same blocks
(``reports.document``, ``reports.html_page``); every chart of the results and studies is interactive (plotly,
``reports.interactive``; plotly.js is written once beside the pages). With ``--static`` each chart also has its
static PNG + SVG files under ``figures/`` (``reports.charts``, ``reports.study_charts``, matplotlib, for papers),
which REPORT.md shows and the pages link; without it REPORT.md links each chart in its page. The figures are
drawn by ``--jobs`` worker processes (default: one per CPU), and a figure whose inputs did not change since the
previous report in the same folder is taken from it (``reports.figure_cache``). Tables are embedded and written
under ``tables/`` as CSV, Markdown, LaTeX and HTML. The front page answers which integrator and setting is
cheapest per scene at each target error (``--targets``, default 1e-3 1e-6 1e-9 1e-12) beside the scene's chart.
The study tables (``bench.studies``) are read from the database and computed (then stored) when missing, or
recomputed with ``--studies recompute``; ``--studies skip`` leaves their sections out.

The report is the sections of ``SECTIONS``, in order: each is a function ``section(builder, inputs)`` that adds
its blocks to the front page (``index.html``) unless it opens another page (``Builder.page``). A new section is
one function and one line in that list. ``build_report`` works from plain data (a DataFrame with the
``bench.schema`` columns), so it is tested on a small fixture without a database.
"""

from __future__ import annotations

import os
import sys
import time
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import Callable, Mapping

import pandas as pd
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.history.load import load_history
from foucault_bench.bench.history.revisions import group_revisions
from foucault_bench.bench.problems.scene_key import scene_labels
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.schema import COLUMN_NAMES
from foucault_bench.bench.atomic import replacing_folder
from foucault_bench.bench.studies import STUDIES, StudyTables, stored_studies
from foucault_bench.bench.verdicts.pareto import DEFAULT_TARGETS
from foucault_bench.reports import ensembles, halls, result_sections, study_sections
from foucault_bench.reports.builder import INDEX, Builder, ReportInputs, file_stem
from foucault_bench.reports.history_page import write_history
from foucault_bench.reports.html_page import write_pages

Section = Callable[[Builder, ReportInputs], None]

SECTIONS: list[Section] = [
    result_sections.recommendations,
    result_sections.overview,
    result_sections.decisions,
    result_sections.convergence_orders,
    result_sections.adequacy,
    lambda builder, inputs: halls.add_section(builder, inputs.runs),
    lambda builder, inputs: ensembles.add_section(builder, inputs.runs),
    result_sections.scene_pages,
    study_sections.studies,
    study_sections.seed_section,
    result_sections.all_runs,
]
"""The report's sections in order (module docstring): the front page's first, then the pages they open."""


def build_report(inputs: ReportInputs, folder: Path, title: str = "foucault-bench report",
                 progress: bool = False, previous: Path | None = None) -> tuple[Path, Path]:
    """Write the report folder from plain data; return the paths of index.html and REPORT.md. ``progress``
    shows a counter of the figures drawn (on stderr); ``previous``: the folder of the previous report, whose
    unchanged figures are reused (``None``: ``folder`` itself)."""
    missing = [name for name in COLUMN_NAMES if name not in inputs.runs.columns]
    if missing:
        raise InputError(f"results lack the columns {', '.join(missing)} (see bench/schema.py)")
    if inputs.runs.empty:
        raise InputError("no runs to report on")
    builder = Builder(folder, progress, inputs.interactive, inputs.static, inputs.jobs, previous)
    try:
        for section in SECTIONS:
            builder.page(INDEX, "front page")
            section(builder, inputs)
            builder.flush()
        builder.draw_figures()
    finally:
        builder.close()
    return write_pages(folder, title, builder.pages)


# --------------------------------------------------------------------------------------------------------------
# the command (its options: bench.commands.report)
# --------------------------------------------------------------------------------------------------------------
def _provenance(store: ResultsStore, matrix_id: str) -> dict[str, str]:
    runs = store.matrix_runs()
    row = runs[runs["matrix_id"] == matrix_id]
    if row.empty:
        return {"matrix id": matrix_id}
    record = row.iloc[0]
    labels = {"matrix_id": "matrix id", "matrix_name": "matrix", "status": "status", "started_utc": "started (UTC)",
              "finished_utc": "finished (UTC)", "git_commit": "git commit", "code_version": "code version",
              "host": "host", "cpu_model": "CPU", "jobs": "jobs"}
    return {label: str(record[key]) for key, label in labels.items() if key in record and pd.notna(record[key])}


def write_report(db: Path, matrix_id: str | None, out: Path, studies: str = "stored",
                 targets: tuple[float, ...] = DEFAULT_TARGETS, static: bool = False, jobs: int = 1) -> int:
    """``foucault-bench report``: the report of matrix run ``matrix_id`` (``None``: the latest) of database
    ``db`` written to folder ``out``; ``studies`` is ``stored``, ``recompute`` or ``skip``; ``static`` writes
    every chart's PNG and SVG; ``jobs`` worker processes compute the missing studies, draw the figures and write
    the table files. Exit status 0.

    The report is built in a staging folder beside ``out`` and swapped in whole once complete
    (``bench.atomic.replacing_folder``; the command checks ``out`` first): a kill or a full disk leaves the
    previous report. Study tables are computed and stored when missing (all of them with ``recompute``); when
    ``db`` cannot be written they are computed for this report only, with a note saying so.

    pandas keeps the report's text columns as Python strings (``mode.string_storage``; pyarrow's, the default,
    hold the same values): the report selects rows from small frames thousands of times, which costs 24-31 % more
    CPU with pyarrow's strings (bench/PERF.md "The first report: the studies in parts")."""
    started = time.perf_counter()
    with pd.option_context("mode.string_storage", "python"), ResultsStore(db, create=False) as store:
        matrix_id = store.resolve_matrix_id(matrix_id)
        runs = store.frame(matrix_id)
        if runs.empty:
            raise InputError(f"matrix run {matrix_id} in {db} has no stored runs")
        runs = runs.assign(scene=scene_labels(runs))  # a name with two physics is two scenes, never merged
        adequacy = store.adequacy(matrix_id)
        if not adequacy.empty:
            adequacy = adequacy.assign(scene=scene_labels(adequacy, runs))
        revisions = len(group_revisions(store.matrix_runs(), source=str(db)))
        provenance = {"database": str(db), **_provenance(store, matrix_id)}
        # the missing study tables are computed by worker processes while the sections before theirs are built
        no_studies: dict[str, pd.DataFrame] = {}
        tables: AbstractContextManager[Mapping[str, pd.DataFrame]] = (
            nullcontext(no_studies) if studies == "skip"
            else _study_tables(store, db, recompute=studies == "recompute", jobs=jobs))
        with tables as study_tables:
            inputs = ReportInputs(runs=runs, studies=study_tables, adequacy=adequacy, provenance=provenance,
                                  targets=targets, static=static, jobs=jobs, revisions=revisions)
            with replacing_folder(out, "--out", "report") as staging:
                build_report(inputs, staging, progress=True, previous=out)
                if revisions > 1:
                    (staging / "history").mkdir()
                    write_history(load_history(db, repository=Path.cwd()), staging / "history")
            computed = dict(study_tables)  # every table stored, the report's studies section or not
    print(f"report written: {out / 'index.html'} and {out / 'REPORT.md'} ({len(runs)} runs, "
          f"{', '.join(computed) if computed else 'no studies'}; {time.perf_counter() - started:.1f} s)")
    return 0


def _study_tables(store: ResultsStore, db: Path, recompute: bool, jobs: int) -> StudyTables:
    """``StudyTables`` of ``store`` (``jobs`` worker processes), storing what it computes only when the database
    can be written (the file and its folder, where SQLite keeps its journal); else a note names the tables
    computed for this report only."""
    writable = os.access(db, os.W_OK) and os.access(Path(db).resolve().parent, os.W_OK)
    if not writable:
        stored = stored_studies(store, recompute)
        missing = [name for name in STUDIES if name not in stored]
        if missing:
            print(f"note: {db} is read-only: the study tables {', '.join(missing)} are computed for this report "
                  "and not stored", file=sys.stderr)
    return StudyTables(store, recompute=recompute, store_computed=writable, jobs=jobs)


__all__ = ["SECTIONS", "ReportInputs", "build_report", "file_stem", "write_report"]
