"""The report builder's early work (``Builder.start`` and ``place``): work handed to a worker before the sections
are built is done while they are (it begins before the next section is added), its blocks land where the section
that shows them places them, in the page's order, with one worker process or none; work started and never placed
is an error, not a silent loss."""

from __future__ import annotations

import time
from functools import partial
from pathlib import Path

import pytest

from foucault_bench.reports.builder import INDEX, Builder
from foucault_bench.reports.document import Block, Paragraph

WAIT_S = 60.0
"""How long either side waits for the other's file: far above a fork and a file write on a loaded machine."""


def _wait_for(path: Path) -> None:
    deadline = time.monotonic() + WAIT_S
    while not path.exists():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{path.name} did not appear within {WAIT_S:g} s")
        time.sleep(0.01)


def _early_work(folder: Path, wait: bool) -> list[Block]:
    (folder / "began").touch()
    if wait:
        _wait_for(folder / "go")
    return [Paragraph("early 1"), Paragraph("early 2")]


def _texts(builder: Builder, file: str) -> list[str]:
    (page,) = [page for page in builder.pages if page.file == file]
    return [block.text for block in page.blocks if isinstance(block, Paragraph)]


def test_started_work_is_done_while_the_sections_are_built_and_lands_where_it_is_placed(tmp_path: Path) -> None:
    builder = Builder(tmp_path, progress=False, interactive=False, jobs=2)
    builder.start("early", partial(_early_work, tmp_path, True))
    _wait_for(tmp_path / "began")  # begun by a worker: this process has not added a block yet
    builder.add(Paragraph("front"))
    builder.page("other.html", "other")
    builder.add(Paragraph("before"))
    builder.place("early")
    builder.add(Paragraph("after"))
    (tmp_path / "go").touch()
    builder.draw_figures()
    assert _texts(builder, INDEX) == ["front"]
    assert _texts(builder, "other.html") == ["before", "early 1", "early 2", "after"]


def test_with_one_job_started_work_is_done_with_the_figures_and_lands_in_the_same_place(tmp_path: Path) -> None:
    builder = Builder(tmp_path, progress=False, interactive=False, jobs=1)
    builder.start("early", partial(_early_work, tmp_path, False))
    assert not (tmp_path / "began").exists()  # no worker: nothing is done before draw_figures
    builder.add(Paragraph("before"))
    builder.place("early")
    builder.add(Paragraph("after"))
    builder.draw_figures()
    assert _texts(builder, INDEX) == ["before", "early 1", "early 2", "after"]


def test_work_started_and_never_placed_is_an_error(tmp_path: Path) -> None:
    builder = Builder(tmp_path, progress=False, interactive=False, jobs=2)
    builder.start("forgotten", partial(_early_work, tmp_path, False))
    with pytest.raises(RuntimeError, match="work started but never placed: forgotten"):
        builder.draw_figures()
