"""The CI gate (``foucault-bench check``): a thresholds file checked on stored rows or on a fresh matrix run.

``check`` ties the gate together: read the thresholds (``bench.gate.thresholds``), get the rows — a stored
matrix run, or a matrix run now after validating the thresholds against its planned rows
(``bench.gate.select``), so that bad input is found before anything runs — evaluate every bound
(``bench.gate.evaluate``) and render the outcomes (``bench.gate.render``). The command's options are in
``bench.commands.check``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import pandas as pd

from foucault_bench.bench.gate.select import planned_rows, validate_against
from foucault_bench.bench.gate.thresholds import Thresholds


def run_for_check(thresholds: Thresholds, matrix_name: str, *, db: str | None, jobs: int,
                  progress: bool, run_timeout_s: float | None = None) -> tuple[pd.DataFrame, str]:
    """Validate ``thresholds`` against the planned runs of the matrix (before anything runs), run the matrix
    into ``db`` (a temporary database when ``None``) with the per-run time limit ``run_timeout_s`` (the
    matrix's when ``None``) and return its rows and a description of them."""
    from foucault_bench.bench.run.runner import LocalExecutor, run_matrix

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
