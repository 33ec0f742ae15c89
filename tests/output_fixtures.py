"""Helpers of the tests of safe outputs (test_safe_outputs.py, test_report_kill.py): a tiny results database, a
``foucault-bench report`` that draws one figure and no seed section, a digest of a folder's files, and running
a command where a folder is read-only or a disk is full (a private mount namespace, as root)."""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np

from foucault_bench.bench.atomic import MARKER

QUICK_REPORT = """
import sys
import matplotlib
matplotlib.rcParams["svg.hashsalt"] = "fixed"  # with SOURCE_DATE_EPOCH: the same SVG bytes every build
import foucault_bench.reports.build as build
from foucault_bench.reports import result_sections, study_sections
build.SECTIONS.remove(study_sections.seed_section)  # the seed section is tested in test_seed.py
result_sections._scene_work_precision = lambda *arguments: None  # one figure (convergence) is enough to test
build.SECTIONS.remove(result_sections.recommendations)  # the writing (its charts are work-precision charts)
{extra}
from foucault_bench.bench.cli import main
sys.exit(main(["report", *sys.argv[1:]]))
"""
"""A ``foucault-bench report`` (arguments after the script) with one figure and no seed section; ``extra``:
lines run before it (e.g. a patch that kills the process at a chosen point)."""

QUICK_ENVIRONMENT = {**os.environ, "SOURCE_DATE_EPOCH": "1700000000", "PYTHONUNBUFFERED": "1"}

CAN_MOUNT = sys.platform.startswith("linux") and hasattr(os, "geteuid") and os.geteuid() == 0 \
    and shutil.which("unshare") is not None and shutil.which("mount") is not None
"""Root with ``unshare``: a private mount namespace can hold a small tmpfs (a full disk) or a read-only bind
mount; root ignores file permissions, so this is also the only way to make a folder read-only to root."""


def tiny_database(path: Path, integrator: str = "rk4") -> str:
    """A results database with one finished matrix run of three fixed-step runs of scene ``lab``, every verdict
    filled; returns the matrix id."""
    from foucault_bench.bench.run.matrix import Matrix
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.run.timing import TimingPolicy
    from foucault_bench.bench.schema import COLUMN_NAMES

    matrix = Matrix(name="tiny", description="safe outputs", source="tests/output_fixtures.py", scenes=(), runs=(),
                    plugins=(), timing=TimingPolicy())
    with ResultsStore(path) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        for kh in (0.4, 0.2, 0.1):
            error = 1e-2 * (kh / 2) ** 4
            row = dict.fromkeys(COLUMN_NAMES, np.nan)
            row.update(run_key=f"lab-{integrator}-{kh}", matrix_id=matrix_id, scene="lab", model="linear",
                       integrator=integrator, family="runge-kutta", status="ok", message="", duration_s=60.0,
                       n_out=601, kh=kh, step_s=kh / 2, reference_error=error, energy_max_rel_error=0.1 * error,
                       energy_drift_per_s=1e-3 * error, precession_rate_ref_error=0.5 * error,
                       precession_rate_error=0.5 * error + 1e-4, analytic_gap_exact=error + 1e-7,
                       wall_time_s=1e-3 / kh, cpu_time_s=1e-3 / kh, nfev=int(1000 / kh))
            store.write_run(row)
        store.finish_matrix_run(matrix_id)
    return matrix_id


def quick_report_command(*arguments: str | Path, extra: str = "") -> list[str]:
    return [sys.executable, "-c", QUICK_REPORT.format(extra=extra), *map(str, arguments)]


def folder_digest(folder: Path) -> dict[str, str]:
    """Relative path → SHA-256 of every file under ``folder``; the marker's content (it holds a time) is left
    out, its presence is kept."""
    digest = {}
    for path in sorted(folder.rglob("*")):
        if path.is_file():
            name = path.relative_to(folder).as_posix()
            digest[name] = "marker" if name == MARKER else hashlib.sha256(path.read_bytes()).hexdigest()
    return digest


def leftovers(folder: Path) -> list[str]:
    """Temporary files and folders of the atomic writers in ``folder`` (``bench.atomic``)."""
    return sorted(entry.name for entry in folder.iterdir()
                  if entry.name.startswith(".") and any(f".{kind}-" in entry.name
                                                        for kind in ("partial", "building", "previous")))


def alive(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie (an orphan's zombie waits for a reaper that a container's
    first process may never be)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state != "Z"


def processes_running(text: str) -> list[int]:
    """The ids of the live processes (``alive``) whose command line holds ``text``."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and text in (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode():
                found.append(int(entry.name))
        except OSError:  # ended while being read
            continue
    return [pid for pid in found if alive(pid)]


def in_mount_namespace(setup: str, command: list[str], teardown: str = "", timeout: float | None = None,
                       **kwargs) -> subprocess.CompletedProcess:
    """Run ``command`` between the shell lines ``setup`` (mounts) and ``teardown`` in a private mount namespace
    (``CAN_MOUNT``); the exit status is the command's. Past ``timeout`` seconds the whole process group is killed,
    the command's own children too (a report's pool workers), and ``subprocess.TimeoutExpired`` raised: a hung
    command fails its test and leaves no process behind."""
    script = f"set -e\n{setup}\nset +e\n\"$@\"\nstatus=$?\n{teardown}\nexit $status"
    with subprocess.Popen(["unshare", "-m", "--propagation", "private", "sh", "-c", script, "sh", *command],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                          **kwargs) as process:
        try:
            stdout, stderr = process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
            raise
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)


def full_disk(folder: Path, size_kb: int) -> tuple[str, str, Path]:
    """(setup, teardown, after) for ``in_mount_namespace``: ``folder`` becomes a tmpfs of ``size_kb`` holding a
    copy of its files, filled up with a filler file so that every write there fails with ENOSPC; afterwards its
    files (without the filler) are copied to ``after``, which the test reads (the tmpfs ends with the namespace)."""
    after = folder.with_name(folder.name + ".after")
    setup = (f"cp -a {folder} {folder}.copy\nmount -t tmpfs -o size={size_kb}k tmpfs {folder}\n"
             f"cp -a {folder}.copy/. {folder}/\nrm -rf {folder}.copy\n"
             f"dd if=/dev/zero of={folder}/filler bs=4k 2>/dev/null || true\n"
             f"dd if=/dev/zero of={folder}/filler2 bs=1 2>/dev/null || true")
    teardown = f"mkdir {after}\ncp -a {folder}/. {after}/\nrm -f {after}/filler {after}/filler2"
    return setup, teardown, after


def read_only_setup(folder: Path) -> str:
    """Shell lines making ``folder`` read-only (a read-only bind mount of itself)."""
    return f"mount --bind {folder} {folder}\nmount -o remount,ro,bind {folder} {folder}"
