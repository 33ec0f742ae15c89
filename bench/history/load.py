"""Reading a results database as a history: its revisions in order, its rows lined up, the changes between them.

``load_history`` is what ``foucault-bench history`` shows and what ``check --baseline`` and the report's
history page build on. Selecting scenes and integrators by name is checked against the stored rows: an unknown
name is an ``InputError`` with the closest stored one.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import pandas as pd

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.history.changes import Change, history_changes, lined_up
from foucault_bench.bench.history.revisions import Revision, ordered_revisions
from foucault_bench.bench.validation import suggestion


@dataclass(frozen=True)
class History:
    """Revisions (in order), how they were ordered, the lined-up rows and the changes between revisions."""

    revisions: tuple[Revision, ...]
    ordered_by: str
    rows: pd.DataFrame
    changes: tuple[Change, ...]


def _check_names(option: str, wanted: Sequence[str], stored: Sequence[str], problems: list[str]) -> None:
    known = sorted(set(stored))
    for name in wanted:
        if name not in known:
            problems.append(f"{option} {name!r}: no stored row has it{suggestion(name, known)}")


def load_history(db: str | Path, *, scenes: Sequence[str] = (), integrators: Sequence[str] = (),
                 repository: Path | None = None) -> History:
    """The history of the runs in ``db`` (every matrix run), restricted to ``scenes`` (names or displayed
    labels) and ``integrators`` when given; ``repository`` orders the revisions by its commits."""
    from foucault_bench.bench.run.store import ResultsStore

    with ResultsStore(db, create=False) as store:
        matrix_runs = store.matrix_runs()
        frame = store.frame(all_runs=True)
    revisions, ordered_by = ordered_revisions(matrix_runs, source=str(db), repository=repository)
    rows = lined_up(frame, revisions)
    machines = matrix_runs.set_index("matrix_id")["cpu_model"]
    rows["cpu_model"] = rows["matrix_id"].map(machines)
    problems: list[str] = []
    _check_names("--scene", scenes, [*rows["scene"], *rows["scene_label"]], problems)
    _check_names("--integrator", integrators, list(rows["integrator"]), problems)
    if problems:
        raise InputError(problems)
    if scenes:
        rows = rows[rows["scene"].isin(scenes) | rows["scene_label"].isin(scenes)]
    if integrators:
        rows = rows[rows["integrator"].isin(integrators)]
    return History(tuple(revisions), ordered_by, rows, tuple(history_changes(rows)))
