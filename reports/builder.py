"""The report under construction: its pages of blocks, the figures still to draw, and the tables written beside.

Sections (``reports.build.SECTIONS``) add blocks to a ``Builder``: ``page`` opens a page (``index.html``, one
page per scene, the studies, all runs), ``add`` appends headings and paragraphs, ``table`` shows a table and
queues the writing of its files, ``figure`` and ``curves`` keep a place for a chart. The queued work (charts and
table files) is done by worker processes while the sections go on: after each section ``flush`` hands what was
queued to one worker (the sections use the other core), and ``draw_figures`` does the rest on ``jobs`` workers
once every section has run. Blocks land in the page's order whatever order they finish in; a progress bar names
each item done. A figure whose inputs did not change since the previous build of the same folder is not drawn
again (``reports.figure_cache``): its blocks and static files are taken from that build.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import multiprocessing.context
import queue
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Mapping

import pandas as pd
from foucault_bench.bench.verdicts.pareto import DEFAULT_TARGETS
from matplotlib.figure import Figure as MplFigure
from tqdm import tqdm

from foucault_bench.bench.parent_death import PoolTasks, outcome, stop_pools, worker_pool
from foucault_bench.reports import chart_style, interactive, plotly_conversion, tables
from foucault_bench.reports.document import Block, Figure, Page, Paragraph, Table, display_frame, write_table_files
from foucault_bench.reports.figure_cache import FigureCache, Unhashable, digest

if TYPE_CHECKING:
    from foucault_bench.reports.plotly_figure import Plot

FIGURES = "figures"
TABLES = "tables"
INDEX = "index.html"


@dataclass
class ReportInputs:
    """Everything a report is made of, as plain data.

    Attributes:
        runs: results rows (columns of ``bench.schema``).
        studies: study name (``bench.studies.STUDIES``) → its table; missing names leave their section out. A
            ``bench.studies.StudyTables`` may still be computing them: only the studies' sections look them up.
        adequacy: rows of the ``adequacy`` table (scene, model, simpler_model, precession_rate_diff,
            trajectory_gap, note), possibly empty.
        provenance: label → value lines shown at the top (matrix id, host, commit, ...).
        targets: target reference errors of the matched-accuracy summary.
        interactive: draw the charts of index.html with plotly (else the static PNGs only).
        static: write every chart's PNG and SVG under figures/ (else only those of the charts that are not
            interactive); REPORT.md shows the static files or links to index.html.
        jobs: worker processes drawing the figures (1: in this process).
        revisions: code revisions whose runs the database holds (``bench.history``); with more than one, the
            report links its history page (``history/history.html``, ``reports.history_page``).
    """

    runs: pd.DataFrame
    studies: Mapping[str, pd.DataFrame] = field(default_factory=dict)
    adequacy: pd.DataFrame = field(default_factory=pd.DataFrame)
    provenance: dict[str, str] = field(default_factory=dict)
    targets: tuple[float, ...] = DEFAULT_TARGETS
    interactive: bool = True
    static: bool = True
    jobs: int = 1
    revisions: int = 1


def file_stem(name: str) -> str:
    """A file-name part for a scene name, the same on every file system and distinct for distinct names.

    Scene names hold letters, digits, ``_``, ``.`` and ``-`` (``bench.problems.scenes.SCENE_NAME_PATTERN``).
    A dot would start a file suffix (``seed_v1.5`` and ``seed_v1.6`` would share ``seed_v1``), and names that
    differ only in case collide on case-insensitive file systems, so ``-`` escapes: ``-`` → ``--``, ``.`` →
    ``-_``, an upper-case letter X → ``-x``. The escape is prefix-free, hence one-to-one; lower-case names
    without dots or dashes (every built-in scene) are unchanged."""
    parts = []
    for character in name:
        if character == "-":
            parts.append("--")
        elif character == ".":
            parts.append("-_")
        elif character.isupper():
            parts.append("-" + character.lower())
        else:
            parts.append(character)
    return "".join(parts)


def scene_page(scene: str) -> str:
    """The file name of a scene's page."""
    return f"scene_{file_stem(scene)}.html"


_PENDING: list[Callable[[], list[Block]]] = []
"""The work queued by the report being built (charts to draw, table files to write), read by position by the
worker processes of ``Builder`` (which inherit it by fork: nothing is pickled but the blocks they return)."""


def _do_pending(position: int) -> tuple[int, list[Block]]:
    return position, _PENDING[position]()


def _fork_context() -> multiprocessing.context.BaseContext | None:
    """The fork start method where the platform has it (worker processes inherit the figures to draw), else
    ``None`` (the figures are drawn in this process)."""
    return multiprocessing.get_context("fork") if "fork" in multiprocessing.get_all_start_methods() else None


@dataclass
class _Pending:
    """Queued work: ``draw()`` returns the blocks for a place kept on ``page`` at index ``place`` (a chart), or
    writes files and returns nothing (``page`` None: a table's files); ``what`` names it in the progress bar,
    ``key`` is the digest of its inputs (``figure_cache.digest``; ``None``: always done)."""

    page: Page | None
    place: int
    what: str
    draw: Callable[[], list[Block]]
    key: str | None
    long: bool = False
    blocks: list[Block] = field(default_factory=list)


class Builder:
    """Collects the pages' blocks while writing the figures and tables they point to.

    ``previous``: the folder of the previous build of this report (the figure cache is read from it; ``None``:
    ``folder`` itself)."""

    def __init__(self, folder: Path, progress: bool, interactive: bool, static: bool = True, jobs: int = 1,
                 previous: Path | None = None):
        self.folder = folder
        self.interactive = interactive
        self.static = static
        self.progress = progress
        self.jobs = jobs
        self.cache = FigureCache(folder, previous if previous is not None else folder)
        self.pages: list[Page] = []
        self.current = self.page(INDEX, "front page")
        self.pending: list[_Pending] = []
        self._queued = 0  # pending[:_queued] are handed to workers (or reused from the cache)
        self._todo: list[_Pending] = []  # the tasks handed to workers, by their position in _PENDING
        self._done: queue.Queue[tuple[int, list[Block]] | BaseException] = queue.Queue()
        self._pools: list[PoolTasks] = []
        self._background: concurrent.futures.ProcessPoolExecutor | None = None  # the one-worker pool of the last flush
        self._unfinished = 0  # tasks handed to the background pool and not yet finished (no flush until 0)

    def page(self, file: str, title: str) -> Page:
        """Make page ``file`` (created with ``title`` on first use) the one blocks are added to; return it."""
        found = next((page for page in self.pages if page.file == file), None)
        if found is None:
            found = Page(file, title, [])
            self.pages.append(found)
        self.current = found
        return found

    def add(self, *blocks: Block) -> None:
        self.current.blocks.extend(blocks)

    def later(self, what: str, draw: Callable[[], list[Block]], long: bool = False, key: object = None) -> None:
        """Keep a place for the blocks ``draw()`` returns (figures, which ``draw_figures`` draws in parallel);
        ``what`` names them in the progress bar; ``long`` starts them first; ``key``: everything the blocks
        depend on (hashed with the drawing code's version), or ``None`` to draw them on every build (as when
        ``key`` holds a lambda or a closure, whose captured data the hash cannot see)."""
        try:
            found = None if key is None else digest((what, key), self.folder)
        except Unhashable:
            found = None
        self.pending.append(_Pending(self.current, len(self.current.blocks), what, draw, found, long))
        self.current.blocks.append(Paragraph(""))

    def figure(self, name: str, caption: str, draw: Callable[[Path], Path],
               draw_interactive: Callable[[], Plot] | None = None, beside: bool = False) -> None:
        """Add a chart to the page; ``draw_figures`` later writes the static chart ``draw(stem)`` under figures/
        (when the report is static) and, when the report is interactive, puts the plotly figure
        ``draw_interactive()`` on the page; ``beside``: to the right of the table just added."""
        static = self.static or not (self.interactive and draw_interactive is not None)
        block = Figure(f"{FIGURES}/{name}", caption, static=static, beside=beside)
        on_page = draw_interactive if self.interactive else None
        self.later(name, partial(_render_figure, block, self.folder / FIGURES / name, draw, on_page),
                   key=(block, draw, on_page))

    def curves(self, name: str, caption: str, draw: Callable[[pd.DataFrame], MplFigure], table: pd.DataFrame) -> None:
        """A chart of curves drawn with matplotlib (``draw(table)``): saved under figures/, and on the page
        converted to plotly (``plotly_conversion.from_matplotlib``)."""
        block = Figure(f"{FIGURES}/{name}", caption, static=self.static or not self.interactive)
        self.later(name, partial(_render_curves, block, self.folder / FIGURES / name, draw, table, self.interactive),
                   key=(block, draw, table, self.interactive))

    def table(self, frame: pd.DataFrame, name: str, title: str, notes: dict[str, str] | None = None,
              collapsible: bool = False, details: str | None = None) -> None:
        """Show ``frame`` (folded when ``collapsible``; ``details``: a text column shown as a folded row under
        each row instead of a cell) and queue the writing of its files under tables/ (``table_files``)."""
        shown = display_frame(frame, tables.COLUMN_FORMATS)
        self.table_files(frame, name, title, shown)
        self.add(Table(title, shown, f"{TABLES}/{name}", tables.notes_for(frame, notes), collapsible, details))

    def table_files(self, frame: pd.DataFrame, name: str, title: str, shown: pd.DataFrame | None = None) -> None:
        """Queue the writing of ``frame``'s files ``tables/<name>.csv``, ``.md``, ``.tex``, ``.html``
        (``document.write_table_files``; ``shown``: its formatted cells when already made)."""
        self.pending.append(_Pending(None, 0, f"{TABLES}/{name}", partial(
            _write_files, frame, self.folder, f"{TABLES}/{name}", title, shown), None))

    def flush(self) -> None:
        """Hand the work queued since the last call to one worker process, if the previous handful is done (the
        sections go on in this process, on the other core); with one job, or without the fork start method,
        nothing (``draw_figures`` does it all)."""
        context = _fork_context()
        if self.jobs < 2 or context is None or self._unfinished:
            return
        tasks = self._take_queued()
        if not tasks:
            return
        if self._background is not None:
            self._background.shutdown(wait=True)  # its tasks are done (``_unfinished`` is 0): its worker ends now
        self._background = worker_pool(context, 1)
        self._submit(self._background, tasks, background=True)

    def _take_queued(self) -> list[_Pending]:
        """The queued tasks not yet handed out, those found in the figure cache left out (their blocks set);
        longest first; each appended to ``_PENDING`` (for the workers forked after this)."""
        tasks = []
        for task in self.pending[self._queued:]:
            reused = self.cache.reuse(task.key) if task.key is not None else None
            if reused is None:
                tasks.append(task)
            else:
                task.blocks = reused
        self._queued = len(self.pending)
        tasks.sort(key=lambda task: not task.long)
        assert len(_PENDING) == len(self._todo), "one report is built at a time"
        _PENDING.extend(task.draw for task in tasks)
        self._todo.extend(tasks)
        return tasks

    def _submit(self, pool: concurrent.futures.ProcessPoolExecutor, tasks: list[_Pending],
                background: bool = False) -> None:
        """Run ``tasks`` (the last ``len(tasks)`` of ``_PENDING``) on ``pool``; results (or errors) reach
        ``_done``."""
        first = len(_PENDING) - len(tasks)

        def finished(future: concurrent.futures.Future) -> None:
            if future.cancelled():
                return
            if background:
                self._unfinished -= 1
            self._done.put(outcome(future))

        if background:
            self._unfinished += len(tasks)
        futures: list[concurrent.futures.Future] = []
        self._pools.append((pool, futures))  # before its tasks: whatever happens below, close() stops it
        for position in range(first, len(_PENDING)):
            futures.append(pool.submit(_do_pending, position))
            futures[-1].add_done_callback(finished)

    def draw_figures(self) -> None:
        """Do the queued work not yet handed out (charts not in the cache, table files) on ``jobs`` worker
        processes when there are several, and wait for all of it, with a bar that knows the total (and so shows
        an ETA) and names the item last done; blocks keep their order. Writes the cache of this build
        (``figure_cache``)."""
        try:
            self._finish()
        finally:
            self.close()
        charts = [task for task in self.pending if task.page is not None]
        for task in sorted(charts, key=lambda task: -task.place):
            if task.page is not None:
                task.page.blocks[task.place:task.place + 1] = task.blocks
        drawn = {id(task) for task in self._todo}
        self.cache.write({task.key: task.blocks for task in charts if task.key is not None},
                         drawn=[task.what for task in charts if id(task) in drawn],
                         reused=[task.what for task in charts if id(task) not in drawn])
        self.pending, self._todo, self._queued = [], [], 0

    def close(self) -> None:
        """Stop the worker processes and forget the queued work (after ``draw_figures``, or when a section
        failed): the tasks not yet started are cancelled, and this returns when the running ones have ended, so
        that no worker writes into the folder afterwards (``bench.parent_death.stop_pools``)."""
        pools, self._pools, self._background = self._pools, [], None
        try:
            stop_pools(pools)
        finally:
            _PENDING.clear()

    def _finish(self) -> None:
        tasks = self._take_queued()
        charts = sum(task.page is not None for task in self.pending)
        reused = charts - sum(task.page is not None for task in self._todo)
        bar = tqdm(total=len(self._todo), desc=f"report figures and tables ({reused} figures unchanged)",
                   unit="item", disable=not self.progress, leave=False)
        context = _fork_context()
        jobs = min(self.jobs, len(tasks))
        here: list[int] = []  # positions done in this process, one at a time between the workers' results
        if jobs > 1 and context is not None:
            self._submit(worker_pool(context, jobs), tasks)
        else:
            here = list(range(len(_PENDING) - len(tasks), len(_PENDING)))
        try:
            for _ in range(len(self._todo)):
                result = _do_pending(here.pop(0)) if here and self._done.empty() else self._done.get()
                if isinstance(result, BaseException):
                    raise result
                position, blocks = result
                self._todo[position].blocks = blocks
                bar.set_postfix_str(f"done {self._todo[position].what}", refresh=False)
                bar.update()
        finally:
            bar.close()


def _write_files(frame: pd.DataFrame, folder: Path, stem: str, caption: str,
                 shown: pd.DataFrame | None) -> list[Block]:
    """A queued table's files (``document.write_table_files``); no blocks."""
    write_table_files(frame, folder, stem, caption, tables.COLUMN_FORMATS, shown=shown)
    return []


def _render_figure(block: Figure, stem: Path, draw: Callable[[Path], Path],
                   draw_interactive: Callable[[], Plot] | None) -> list[Block]:
    """Draw one chart: its static files when ``block.static``, its plotly figure when ``draw_interactive``."""
    if block.static:
        draw(stem)
    if draw_interactive is not None:
        plot = draw_interactive()
        block.interactive, block.points = plot.to_json(), interactive.drawn_points(plot)
    return [block]


def _render_curves(block: Figure, stem: Path, draw: Callable[[pd.DataFrame], MplFigure], table: pd.DataFrame,
                   on_page: bool) -> list[Block]:
    """Draw one matplotlib chart ``draw(table)``: its static files when ``block.static``, and its plotly
    conversion when ``on_page``."""
    figure = draw(table)
    if block.static:
        chart_style.save(figure, stem)
    if on_page:
        plot = plotly_conversion.from_matplotlib(figure)
        block.interactive, block.points = plot.to_json(), interactive.drawn_points(plot)
    return [block]
