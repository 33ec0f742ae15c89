"""``kill -9`` of ``foucault-bench report`` at several points leaves the old report or the new one, whole.

The old report is a complete report of the tiny database with ``--targets 1e-3``; each killed run builds the new
one (``--targets 1e-6``, so that every table differs) into the same folder. The kills come from outside, once
files of given kinds appear in the staging folder (polled, no fixed sleeps), and from inside at exact points: a
patch that sends SIGKILL to its own process before REPORT.md is written, between the two renames of the swap, and
after the swap before the old folder is removed. After each, the folder's files (paths and SHA-256) are the old
report's or a complete new report's (a run that was not killed; SOURCE_DATE_EPOCH and a fixed SVG salt make the
bytes repeatable), and the next run leaves no temporary folder behind.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from foucault_bench.bench.atomic import MARKER, recover
from foucault_bench.bench.cli import main as cli_main
from output_fixtures import (
    QUICK_ENVIRONMENT, alive, folder_digest, leftovers, processes_running, quick_report_command, tiny_database,
)

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX signals")

NEW_TARGETS = ("--targets", "1e-6")

KILL_SELF = """
import os, signal
def kill_self():
    os.kill(os.getpid(), signal.SIGKILL)
"""

KILL_BEFORE_MARKDOWN = KILL_SELF + """
import foucault_bench.reports.html_page as html_page
html_page.render_markdown = lambda *args, **kwargs: kill_self()
"""
"""index.html and plotly.min.js are written, REPORT.md is not (the half-written report of the issue)."""

KILL_BETWEEN_RENAMES = KILL_SELF + """
real_rename = os.rename
def rename(source, destination):
    real_rename(source, destination)
    if ".previous-" in os.fspath(destination):
        kill_self()
os.rename = rename
"""
"""The old report is renamed aside, the new one not yet in place: the folder is missing."""

KILL_BEFORE_REMOVING_THE_OLD = KILL_SELF + """
import shutil
real_rmtree = shutil.rmtree
def rmtree(path, *args, **kwargs):
    if ".previous-" in os.fspath(path):
        kill_self()
    real_rmtree(path, *args, **kwargs)
shutil.rmtree = rmtree
"""


@pytest.fixture(scope="module")
def place(tmp_path_factory):
    """The tiny database and the old report (a complete report written in this process, without figures)."""
    import foucault_bench.reports.build as build
    from foucault_bench.reports import result_sections, study_sections

    folder = tmp_path_factory.mktemp("kill")
    database = folder / "results.sqlite"
    tiny_database(database)
    old = folder / "old"
    patch = pytest.MonkeyPatch()
    patch.setattr(build, "SECTIONS", [section for section in build.SECTIONS
                                      if section not in (study_sections.seed_section, result_sections.recommendations)])
    patch.setattr(result_sections, "_scene_work_precision", lambda *arguments: None)
    try:
        assert cli_main(["report", "--db", str(database), "--out", str(old), "--studies", "skip", "--static",
                         "--targets", "1e-3"]) == 0
    finally:
        patch.undo()
    return {"folder": folder, "database": database, "old": folder_digest(old), "old_folder": old}


def old_report_at(place, name: str) -> Path:
    out = place["folder"] / name / "report"
    out.parent.mkdir()
    shutil.copytree(place["old_folder"], out)
    return out


def new_report(place, out: Path, extra: str = "") -> subprocess.CompletedProcess:
    command = quick_report_command("--db", place["database"], "--out", out, "--studies", "skip", "--static",
                                   *NEW_TARGETS, extra=extra)
    return subprocess.run(command, capture_output=True, text=True, env=QUICK_ENVIRONMENT, timeout=600)


@pytest.fixture(scope="module")
def killed_in_the_window(place):
    """A run killed between the two renames, then the next run (which completes): the complete new report."""
    out = old_report_at(place, "window")
    done = new_report(place, out, KILL_BETWEEN_RENAMES)
    state = {"status": done.returncode, "target_existed": out.exists(),
             "aside": [entry.name for entry in out.parent.iterdir() if ".previous-" in entry.name]}
    recover(out)
    state["recovered"] = folder_digest(out)
    finished = new_report(place, out)
    assert finished.returncode == 0, finished.stderr
    state["next_run"] = folder_digest(out)
    state["leftovers"] = leftovers(out.parent)
    return state


def test_a_kill_between_the_renames_leaves_the_old_report_aside_and_the_next_run_recovers(killed_in_the_window,
                                                                                           place):
    state = killed_in_the_window
    assert state["status"] == -signal.SIGKILL
    assert not state["target_existed"] and len(state["aside"]) == 1  # the window: the old report is aside, whole
    assert state["recovered"] == place["old"]
    assert state["leftovers"] == []


def test_the_next_run_writes_a_complete_new_report(killed_in_the_window, place):
    new = killed_in_the_window["next_run"]
    assert new != place["old"]
    assert {MARKER, "index.html", "REPORT.md", "plotly.min.js", "tables/matched_accuracy.csv"} <= set(new)
    assert any(name.startswith("figures/") and name.endswith(".png") for name in new)
    assert set(new) == set(place["old"])  # the same files, other contents (the targets differ)
    assert new["tables/matched_accuracy.csv"] != place["old"]["tables/matched_accuracy.csv"]


@pytest.mark.parametrize("extra", [KILL_BEFORE_MARKDOWN, KILL_BEFORE_REMOVING_THE_OLD],
                         ids=["before REPORT.md", "after the swap"])
def test_a_kill_at_an_exact_point_leaves_the_old_or_the_new_report(killed_in_the_window, place, extra):
    name = "markdown" if extra is KILL_BEFORE_MARKDOWN else "swapped"
    out = old_report_at(place, name)
    done = new_report(place, out, extra)
    assert done.returncode == -signal.SIGKILL, done.stderr
    expected = place["old"] if extra is KILL_BEFORE_MARKDOWN else killed_in_the_window["next_run"]
    assert folder_digest(out) == expected
    recover(out)
    assert folder_digest(out) == expected and leftovers(out.parent) == []


def _staging_holds(parent: Path, predicate) -> bool:
    return any(predicate(staging) for staging in parent.glob(".report.building-*"))


@pytest.mark.parametrize("point", ["tables", "figures"])
def test_a_kill_from_outside_while_building_leaves_the_old_report(killed_in_the_window, place, point):
    out = old_report_at(place, f"outside-{point}")
    command = quick_report_command("--db", place["database"], "--out", out, "--studies", "skip", "--static",
                                   *NEW_TARGETS)
    predicate = {"tables": lambda staging: len(list((staging / "tables").glob("*"))) >= 8,
                 "figures": lambda staging: any((staging / "figures").glob("*.png"))}[point]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=QUICK_ENVIRONMENT)
    try:
        while process.poll() is None and not _staging_holds(out.parent, predicate):
            time.sleep(0.005)
        process.send_signal(signal.SIGKILL)
    finally:
        status = process.wait(timeout=600)
    assert status == -signal.SIGKILL, "the build ended before the point was reached"
    assert folder_digest(out) == place["old"]
    assert len(list(out.parent.glob(".report.building-*"))) == 1  # the killed build's staging folder, ignored
    recover(out)  # what the next run does first: the killed build's staging folder goes
    assert folder_digest(out) == place["old"] and leftovers(out.parent) == []


INTERRUPTIBLE_AND_SLOW = """
import signal, time
import foucault_bench.reports.builder as builder
signal.signal(signal.SIGINT, signal.default_int_handler)  # a process started in the background may inherit it ignored
_write_files = builder._write_files
def slow_write_files(*arguments, **keywords):  # each table's files, then a pause: the workers are busy at the Ctrl-C
    blocks = _write_files(*arguments, **keywords)
    time.sleep(1.0)
    return blocks
builder._write_files = slow_write_files
"""


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads process states from /proc")
def test_ctrl_c_while_workers_write_ends_the_report_and_its_workers_and_keeps_the_old_one(place) -> None:
    """A Ctrl-C reaches the whole process group while the workers write table files: the report exits with
    status 130 and one line, no traceback (its workers ignore the signal; the report stops them, letting the
    task under way end: ``bench.parent_death``), no process of it is left, and the old report is whole."""
    out = old_report_at(place, "ctrl-c")
    command = quick_report_command("--db", place["database"], "--out", out, "--studies", "skip", "--static",
                                   *NEW_TARGETS, extra=INTERRUPTIBLE_AND_SLOW)
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               env=QUICK_ENVIRONMENT, start_new_session=True)
    try:
        while process.poll() is None and not _staging_holds(out.parent, lambda staging: any(
                (staging / "tables").glob("*.csv"))):
            time.sleep(0.005)
        os.killpg(process.pid, signal.SIGINT)
    finally:
        _, stderr = process.communicate(timeout=600)
    assert process.returncode == 130, stderr[-2000:]
    said = [line for line in re.split(r"[\r\n]", stderr) if line.strip() and not line.startswith("report figures")]
    assert said == ["interrupted"], stderr[-2000:]  # before: "Process ForkPoolWorker-1:" (and its traceback)
    assert processes_running(str(out)) == []
    assert folder_digest(out) == place["old"]
    recover(out)
    assert folder_digest(out) == place["old"] and leftovers(out.parent) == []


POOL_OWNER = """
import multiprocessing, os, sys, time
from foucault_bench.bench.parent_death import worker_pool
pool = worker_pool(multiprocessing.get_context("fork"), 2)
pool.submit(time.sleep, 600.0)  # a worker busy with a long task, as one drawing a chart
print(" ".join(str(process.pid) for process in multiprocessing.active_children()), flush=True)
time.sleep(600.0)
"""


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads process states from /proc")
def test_the_report_s_workers_end_when_the_report_is_killed() -> None:
    """The report's fork workers end with it: a worker left drawing after a kill from outside would write into
    the staging folder the next build has removed (test_a_kill_from_outside_while_building_leaves_the_old_report
    once found such a folder recreated after ``recover``). Without ``die_with_parent`` the busy worker goes on with
    its 10-minute task (the idle one ends when its task queue closes); with it both end at once (30 s allowed)."""
    import sys

    owner = subprocess.Popen([sys.executable, "-c", POOL_OWNER], stdout=subprocess.PIPE, text=True)
    try:
        assert owner.stdout is not None
        workers = [int(pid) for pid in owner.stdout.readline().split()]
        assert len(workers) == 2 and all(alive(pid) for pid in workers)
    finally:
        owner.kill()
        owner.wait(timeout=60)
    deadline = time.monotonic() + 30.0
    while any(alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(alive(pid) for pid in workers), workers


STOPPED_POOL = """
import json, multiprocessing, os, sys, time
from pathlib import Path
from foucault_bench.bench.parent_death import stop_pools, worker_pool

folder = Path(sys.argv[1])

def slow_write(index):
    time.sleep(1.0)
    (folder / f"{index}.txt").write_text("done")
    return index

def crash():
    time.sleep(0.3)
    os._exit(3)

def large_result():  # more than a pipe holds: its worker is still sending it when the pool breaks
    time.sleep(1.0)
    return b"x" * 200_000

pool = worker_pool(multiprocessing.get_context("fork"), 2)
futures = [pool.submit(slow_write, index) for index in range(20)]
time.sleep(0.3)  # two tasks running, a few queued for the workers, the rest waiting in the parent
stop_pools([(pool, futures)])
outcome = {"written": sorted(int(path.stem) for path in folder.glob("*.txt")),
           "finished": sorted(future.result() for future in futures if not future.cancelled()),
           "cancelled": sum(future.cancelled() for future in futures)}
time.sleep(1.5)  # a task still running would write now
outcome["written later"] = sorted(int(path.stem) for path in folder.glob("*.txt"))

pool = worker_pool(multiprocessing.get_context("fork"), 2)
futures = [pool.submit(crash), pool.submit(large_result), pool.submit(large_result)]  # a worker dies: broken
outcome["broken"] = [type(future.exception()).__name__ for future in futures]
stop_pools([(pool, futures)])
print(json.dumps(outcome), flush=True)
"""


def test_a_stopped_pool_lets_its_running_tasks_end_and_nothing_writes_after(tmp_path: Path) -> None:
    """``stop_pools`` (the report's and the studies' pools) kills nothing: ``multiprocessing.Pool.terminate()``,
    used before, killed workers that could be sending a result and then waited for the lock they held, for ever
    (a report whose section failed while figures were drawn hung in ``test_a_full_disk_while_building_a_report``).
    So: the tasks running when it is called end and write their files, the others are cancelled, and no file
    appears after it returns. A worker that dies in a task breaks the pool: its tasks end with
    ``BrokenProcessPool``, the executor ends the other worker (with SIGTERM, which the workers must not ignore:
    one still sending a large result would wait for ever) and stopping the pool returns."""
    import sys

    done = subprocess.run([sys.executable, "-c", STOPPED_POOL, str(tmp_path)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    outcome = json.loads(done.stdout)
    assert outcome["written"] == outcome["finished"] == outcome["written later"], outcome
    assert 2 <= len(outcome["finished"]) < 20 and outcome["cancelled"] == 20 - len(outcome["finished"]), outcome
    assert outcome["broken"] == ["BrokenProcessPool"] * 3, outcome
