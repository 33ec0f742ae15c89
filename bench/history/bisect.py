"""Bisection over commits: the first commit between a good and a bad revision that changed one run's verdict.

Each tested commit is checked out as a detached git worktree in a temporary folder and put first on the import
path of a fresh interpreter (the installed package's own finder removed, so that the commit's code and nothing
else runs), which runs a one-run matrix (the scene, the integrator, one ``kh`` or ``tol``) with that commit's
command line into a database of its own; the verdict is read back with today's store, which reads older schema
versions. The verdict of each commit is compared bit for bit with the good revision's. The commits tested are the
ancestry path from good to bad (``git rev-list --ancestry-path``), halved each time as ``git bisect`` does; a
commit where the run cannot be made (a scene or integrator it does not have, a failing install) is skipped and
its neighbours are tried, and the answer then says which commits were skipped.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

from foucault_bench.bench.errors import InputError

BISECT_TIMEOUT_S = 1800.0
"""Time limit of one tested commit's run (install, compile and the run itself)."""


@dataclass(frozen=True)
class Configuration:
    """The one run bisected: scene, integrator, a fixed step (``kh``) or a tolerance (``tol``), the verdict."""

    scene: str
    integrator: str
    verdict: str
    kh: float | None = None
    tol: float | None = None

    def matrix_toml(self) -> str:
        setting = f"kh = [{self.kh!r}]" if self.kh is not None else f"tol = [{self.tol!r}]"
        return (f'name = "bisect"\ndescription = "one run, for foucault-bench bisect"\nscenes = ["{self.scene}"]\n'
                f'integrators = ["{self.integrator}"]\n{setting}\n')


@dataclass
class Bisection:
    """The answer: the first commit whose verdict differs from the good one's, the values on both sides, and
    every commit tested (commit → value, or why it was skipped)."""

    first_changed: str
    last_unchanged: str
    value_before: object
    value_after: object
    tested: dict[str, object] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)


def _git(repository: Path, *arguments: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", *arguments], cwd=repository, capture_output=True, text=True, timeout=120)


def resolve(repository: Path, revision: str, option: str) -> str:
    """The full commit hash of ``revision`` in ``repository``; ``InputError`` naming ``option`` when unknown."""
    found = _git(repository, "rev-parse", "--verify", "--quiet", f"{revision}^{{commit}}")
    if found.returncode != 0:
        raise InputError(f"{option} {revision}: not a commit of the git repository {repository}")
    return found.stdout.strip()


def commits_between(repository: Path, good: str, bad: str) -> list[str]:
    """The commits after ``good`` up to ``bad`` (both full hashes) on the ancestry path, oldest first;
    ``InputError`` when ``good`` is not an ancestor of ``bad``."""
    if _git(repository, "merge-base", "--is-ancestor", good, bad).returncode != 0:
        raise InputError(f"--good {good[:10]} is not an ancestor of --bad {bad[:10]}: give an older good revision")
    listed = _git(repository, "rev-list", "--reverse", "--ancestry-path", f"{good}..{bad}")
    return listed.stdout.split()


_RUNNER = """
import sys
sys.path.insert(0, {path!r})
sys.meta_path[:] = [finder for finder in sys.meta_path if "editable" not in repr(finder).lower()]
for name in [name for name in sys.modules if name.startswith("foucault_bench")]:
    del sys.modules[name]
import foucault_bench.bench.cli as cli
if not cli.__file__.startswith({root!r}):
    sys.exit("bisect: imported " + cli.__file__ + " instead of the tested commit's code")
sys.exit(cli.main(["run", "--matrix", {matrix!r}, "--db", {db!r}, "--jobs", "1", "--no-progress"]))
"""


@contextlib.contextmanager
def checked_out(repository: Path, commit: str, folder: Path) -> Iterator[Path]:
    """``commit`` of ``repository`` as a detached git worktree under ``folder`` (an empty folder to create),
    yielded as a folder holding the package ``foucault_bench`` (to put first on an interpreter's import path);
    the worktree is removed afterwards. ``RuntimeError`` with the reason when git cannot check it out."""
    tree = folder / "tree"
    folder.mkdir(parents=True, exist_ok=True)
    added = _git(repository, "worktree", "add", "--detach", str(tree), commit)
    if added.returncode != 0:
        raise RuntimeError(f"git worktree add failed: {added.stderr.strip().splitlines()[-1:]}")
    try:
        package = folder / "path"
        package.mkdir()
        (package / "foucault_bench").symlink_to(tree, target_is_directory=True)
        yield package
    finally:
        _git(repository, "worktree", "remove", "--force", str(tree))


def run_at(repository: Path, commit: str, configuration: Configuration, scratch: Path) -> object:
    """The verdict of ``configuration`` at ``commit`` (a float, or the run's status when it is not ok);
    ``RuntimeError`` with the reason when the run cannot be made there."""
    from foucault_bench.bench.run.store import ResultsStore

    folder = scratch / commit[:12]
    try:
        with checked_out(repository, commit, folder) as package:
            matrix, db = folder / "bisect.toml", folder / "bisect.sqlite"
            matrix.write_text(configuration.matrix_toml(), encoding="utf-8")
            code = _RUNNER.format(path=str(package), root=str(package / "foucault_bench"), matrix=str(matrix),
                                  db=str(db))
            environment = {**os.environ, "NUMBA_CACHE_DIR": str(folder / "numba-cache")}
            done = subprocess.run([sys.executable, "-c", code], cwd=folder, capture_output=True, text=True,
                                  timeout=BISECT_TIMEOUT_S, env=environment)
        if done.returncode != 0:
            lines = (done.stderr or done.stdout).strip().splitlines()
            raise RuntimeError(lines[-1] if lines else f"exit status {done.returncode}")
        with ResultsStore(db, create=False) as store:
            frame = store.frame()
        if len(frame) != 1:
            raise RuntimeError(f"the one-run matrix stored {len(frame)} rows")
        row = frame.iloc[0]
        if row["status"] != "ok":
            return f"status {row['status']}"
        if configuration.verdict not in frame.columns:
            raise RuntimeError(f"no column {configuration.verdict} at this commit")
        value = row[configuration.verdict]
        return float(value) if isinstance(value, (int, float)) else value
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _same(first: object, second: object) -> bool:
    import math

    if isinstance(first, float) and isinstance(second, float):
        return (math.isnan(first) and math.isnan(second)) or first.hex() == second.hex()
    return first == second


def bisect(repository: Path, good: str, bad: str, configuration: Configuration, *,
           progress: Callable[[str], None] = lambda line: None,
           measure: Callable[[str], object] | None = None) -> Bisection:
    """Find the first commit after ``good`` up to ``bad`` whose verdict differs from ``good``'s (module
    docstring). ``measure`` (commit → verdict) replaces running the commit, for tests."""
    good, bad = resolve(repository, good, "--good"), resolve(repository, bad, "--bad")
    commits = commits_between(repository, good, bad)
    if not commits:
        raise InputError("--good and --bad are the same commit: nothing to bisect")
    with tempfile.TemporaryDirectory(prefix="foucault-bisect-") as scratch:
        def value(commit: str) -> object:
            if measure is not None:
                return measure(commit)
            return run_at(repository, commit, configuration, Path(scratch))

        tested: dict[str, object] = {}
        skipped: dict[str, str] = {}
        for commit, option in ((good, "--good"), (bad, "--bad")):
            progress(f"running {option} {commit[:10]}")
            try:
                tested[commit] = value(commit)
            except RuntimeError as error:
                raise InputError(f"{option} {commit[:10]}: the run cannot be made there: {error}") from None
        if _same(tested[good], tested[bad]):
            raise InputError(f"{configuration.verdict} is the same at --good and --bad ({tested[good]!r}): nothing "
                             "changed between them")
        low, high = -1, len(commits) - 1  # commits[low] (good when -1) unchanged, commits[high] changed
        candidates = list(range(low + 1, high))
        while high - low > 1:
            untried = [index for index in candidates if low < index < high and commits[index] not in skipped]
            if not untried:
                break
            middle = min(untried, key=lambda index: abs(index - (low + high) / 2))
            commit = commits[middle]
            progress(f"running {commit[:10]} ({high - low - 1} commit(s) left)")
            try:
                tested[commit] = value(commit)
            except RuntimeError as error:
                skipped[commit] = str(error)
                continue
            if _same(tested[commit], tested[good]):
                low = middle
            else:
                high = middle
        before = good if low < 0 else commits[low]
        return Bisection(first_changed=commits[high], last_unchanged=before, value_before=tested[before],
                         value_after=tested[commits[high]], tested=tested, skipped=skipped)
