"""The CI gate (``foucault-bench check``): a thresholds file checked on stored rows or on a fresh matrix run.

``check`` ties the gate together: read the thresholds (``bench.gate.thresholds``), get the rows — a stored
matrix run (``stored_rows_for_check``: only a finished one, unless the caller allows an unfinished one), or a
matrix run now after validating the thresholds against its planned rows (``bench.gate.select``), so that bad
input is found before anything runs — evaluate every bound (``bench.gate.evaluate``) and render the outcomes
(``bench.gate.render``). The command's options are in ``bench.commands.check``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import pandas as pd

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.gate.select import planned_rows, validate_against
from foucault_bench.bench.gate.thresholds import Thresholds


def run_for_check(thresholds: Thresholds, matrix_name: str, *, db: str | None, jobs: int,
                  progress: bool, run_timeout_s: float | None = None) -> tuple[pd.DataFrame, str]:
    """Validate ``thresholds`` against the planned runs of the matrix (before anything runs), run the matrix
    into ``db`` (a temporary database when ``None``) with the per-run time limit ``run_timeout_s`` (the
    matrix's when ``None``) and return its rows and a description of them."""
    from foucault_bench.bench.run.local_executor import LocalExecutor
    from foucault_bench.bench.run.runner import run_matrix

    executor = LocalExecutor(jobs)  # first: the workers start while the matrix and thresholds are validated
    try:
        from foucault_bench.bench.run.matrix import load_matrix, with_run_timeout
        from foucault_bench.bench.run.store import ResultsStore

        matrix = with_run_timeout(load_matrix(matrix_name), run_timeout_s)
        validate_against(thresholds, planned_rows(matrix), what=f"matrix {matrix.name!r}")
    except BaseException:
        executor.kill()
        raise
    with tempfile.TemporaryDirectory(prefix="foucault-check-") as scratch:
        path = db or str(Path(scratch) / "check.sqlite")
        with ResultsStore(path) as store:
            matrix_id = run_matrix(matrix, store, executor=executor, progress=progress)
            frame = store.frame(matrix_id)
    return frame, f"matrix {matrix.name!r} (run {matrix_id}{f' in {db}' if db else ''})"


def stored_rows_for_check(db: str, matrix_id: str | None, *, allow_unfinished: bool) -> tuple[pd.DataFrame, str]:
    """The rows of a stored matrix run (``matrix_id``: an id, a unique prefix or ``None`` for the latest) and a
    description of them. A matrix run whose status is not ``finished`` (``running``: still running, or killed
    before it could say so; ``interrupted``: stopped by a signal) holds only some of its rows, and a gate on
    them would pass on what is missing: ``InputError`` naming the status and the rows stored, unless
    ``allow_unfinished``, which checks the rows there are and says so on stderr."""
    from foucault_bench.bench.run.store import ResultsStore

    with ResultsStore(db, create=False) as store:
        matrix_id = store.resolve_matrix_id(matrix_id)
        provenance = store.matrix_runs().set_index("matrix_id").loc[matrix_id]
        frame = store.frame(matrix_id)
    status = provenance["status"]
    what = f"matrix run {matrix_id} in {db}"
    if status != "finished":
        state = (f"{what} is {status!r}, not 'finished': {int(provenance['rows_stored'])} of "
                 f"{int(provenance['runs_planned'])} planned rows are stored")
        if not allow_unfinished:
            raise InputError(f"{state}; check a finished run (let it finish, or complete it with `foucault-bench run --resume`), or "
                             "give --allow-unfinished to check the rows there are")
        print(f"note: {state}; checking those rows only (--allow-unfinished)", file=sys.stderr)
        what = f"{what} ({status}: {len(frame)} of {int(provenance['runs_planned'])} rows)"
    return frame, what
