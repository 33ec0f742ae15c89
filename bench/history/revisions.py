"""Revisions: the matrix runs of a results database grouped by the code that made them, in commit order.

Every matrix run records its git commit (``+dirty`` for uncommitted changes, ``None`` outside a checkout) and its
code version (a hash of every source file that determines a row's numbers, ``bench.run.provenance``). A revision
is one git commit, or one code version where the commit is unknown or dirty (two dirty states of one commit are
two revisions). Their order is the repository's topological commit order (oldest first) when a repository that
holds every recorded commit is at hand, else the time of each revision's first matrix run; a dirty revision
sorts after its commit.
"""

from __future__ import annotations

import subprocess
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from foucault_bench.bench.errors import InputError

DIRTY_SUFFIX = "+dirty"


@dataclass(frozen=True)
class Revision:
    """One revision: its label (a short commit, ``abc1234+dirty``, or ``code 0123abcd``), the full commit (or
    ``None``), the code version, its matrix runs (oldest first) and when the first one started."""

    label: str
    git_commit: str | None
    code_version: str
    matrix_ids: tuple[str, ...]
    started_utc: str


def _label(commit: str | None, code_version: str) -> str:
    if commit is None:
        return f"code {code_version[:8]}"
    base = commit.removesuffix(DIRTY_SUFFIX)
    return base[:10] + (f"{DIRTY_SUFFIX} {code_version[:6]}" if commit.endswith(DIRTY_SUFFIX) else "")


def group_revisions(matrix_runs: pd.DataFrame, *, source: str) -> list[Revision]:
    """The revisions of ``matrix_runs`` (the store's provenance table), unordered; ``InputError`` when a
    matrix run records neither a commit nor a code version (a database without provenance)."""
    missing = matrix_runs[matrix_runs["code_version"].isna() & matrix_runs["git_commit"].isna()]
    if len(missing):
        raise InputError(f"{source}: matrix run(s) {', '.join(missing['matrix_id'][:5])} record no code version "
                         "and no git commit: without provenance their rows cannot be put in revision order")
    groups: dict[tuple[str, str], list[pd.Series]] = {}
    for _, run in matrix_runs.sort_values(["started_utc"], kind="stable").iterrows():
        commit = run["git_commit"] if isinstance(run["git_commit"], str) and run["git_commit"] else None
        code = str(run["code_version"]) if isinstance(run["code_version"], str) else ""
        identity = (commit, code) if commit is None or commit.endswith(DIRTY_SUFFIX) else (commit, "")
        groups.setdefault(identity, []).append(run)  # type: ignore[arg-type]
    revisions = []
    for (commit, code), runs in groups.items():
        code_version = code or str(runs[-1]["code_version"])
        revisions.append(Revision(_label(commit, code_version), commit, code_version,
                                  tuple(str(run["matrix_id"]) for run in runs), str(runs[0]["started_utc"])))
    return revisions


def commit_positions(repository: Path) -> dict[str, int]:
    """Full commit hash → position in the repository's topological order (oldest 0); empty when ``repository``
    is not a git repository."""
    try:
        listed = subprocess.run(["git", "rev-list", "--topo-order", "--reverse", "--all"], cwd=repository,
                                capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return {}
    if listed.returncode != 0:
        return {}
    return {commit: position for position, commit in enumerate(listed.stdout.split())}


def ordered_revisions(matrix_runs: pd.DataFrame, *, source: str,
                      repository: Path | None) -> tuple[list[Revision], str]:
    """The revisions in order and how they were ordered (``"git commit order"`` or ``"time"``, with the
    reason)."""
    revisions = group_revisions(matrix_runs, source=source)
    positions = commit_positions(repository) if repository is not None else {}
    commits = {revision.git_commit.removesuffix(DIRTY_SUFFIX) for revision in revisions if revision.git_commit}
    by_time = sorted(revisions, key=lambda revision: revision.started_utc)
    if not positions:
        return by_time, "time (no git repository at hand)"
    unknown = sorted(commits - set(positions))
    if unknown or any(revision.git_commit is None for revision in revisions):
        why = (f"commit {unknown[0][:10]} is not in {repository}" if unknown
               else "some matrix runs record no commit")
        return by_time, f"time ({why})"

    def key(revision: Revision) -> tuple[int, int, str]:
        assert revision.git_commit is not None
        return (positions[revision.git_commit.removesuffix(DIRTY_SUFFIX)],
                int(revision.git_commit.endswith(DIRTY_SUFFIX)), revision.started_utc)

    return sorted(revisions, key=key), "git commit order"
