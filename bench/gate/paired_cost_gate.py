"""``check --cost-paired REV``: each run's cost compared with the code of a git revision, timed in one session.

The revision is checked out in a temporary git worktree (``bench.history.bisect.checked_out``, as ``bisect``
does); its code and the installed code each get a worker process and time the matrix's solves in turn
(``bench.history.paired_cost``: ``PAIRED_CYCLES`` cycles in each of ``PAIRED_PROCESS_SETS`` sets of fresh
workers). Each run then gives one ``paired_cost`` check that fails on a slowdown by the paired rule
(``bench.history.changes.paired_cost_change``). Unlike ``check --baseline --cost``, which compares costs
measured at two different times, both sides here see the same machine: on a busy shared machine that is what
meets the noise targets (bench/PERF.md "Cost changes across revisions").
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Callable

import pandas as pd

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.gate.evaluate import Outcome
from foucault_bench.bench.gate.thresholds import Bound, Selection
from foucault_bench.bench.history.bisect import checked_out, resolve
from foucault_bench.bench.history.changes import paired_cost_change
from foucault_bench.bench.history.paired_cost import Side, paired_times
from foucault_bench.bench.problems.scene_key import scene_labels
from foucault_bench.bench.schema import setting_label
from foucault_bench.bench.validation import git_repository_problem

PAIRED_CYCLES = 5
PAIRED_PROCESS_SETS = 2
"""10 pairs per run (the signed-rank test needs 8), in two sets of workers: the setting measured in
bench/PERF.md."""

Timer = Callable[[list[Side], Path, Callable[[str], None]],
                 tuple[dict[str, list[list]], dict[int, dict[str, list[float]]]]]


def _timed(sides: list[Side], matrix: Path, progress: Callable[[str], None]
           ) -> tuple[dict[str, list[list]], dict[int, dict[str, list[float]]]]:
    return paired_times(matrix, sides, cycles=PAIRED_CYCLES, process_sets=PAIRED_PROCESS_SETS, progress=progress)


def resolved_revision(repository: Path, revision: str) -> str:
    """The commit of ``--cost-paired REV`` in ``--repo``; ``InputError`` (one line) when either is unknown,
    before anything runs."""
    if (problem := git_repository_problem(repository)) is not None:
        raise InputError(problem)
    return resolve(repository.resolve(), revision, "--cost-paired")


def paired_cost_outcomes(matrix: str, frame: pd.DataFrame, repository: Path, revision: str, commit: str, *,
                         first_number: int, progress: Callable[[str], None] = lambda line: None,
                         timer: Timer = _timed) -> list[Outcome]:
    """One ``paired_cost`` check per run of ``matrix`` (a built-in name or a TOML file) that is ok on both sides,
    numbered ``first_number``: the installed code against ``commit`` (``resolved_revision``, named ``revision`` to
    the user) of ``repository``; ``progress`` gets a line per run timed. The scene and setting are labelled as the
    checked rows ``frame`` of the same matrix label them (found by run key: the step a fixed-step loop actually
    took). ``timer`` (sides, matrix, progress → ``paired_times``' answer) replaces the timing, for tests.
    ``InputError`` when the revision's code cannot time the matrix."""
    bound = Bound(first_number, Selection(scenes=()), "paired_cost", "within noise",
                  basis=f"a slowdown against {revision} ({commit[:10]}) timed in the same session "
                        "(bench.history.changes.paired_cost_change)")
    matrix_path = str(Path(matrix).resolve()) if Path(matrix).is_file() else matrix
    with tempfile.TemporaryDirectory(prefix="foucault-paired-") as scratch:
        try:
            with checked_out(repository.resolve(), commit, Path(scratch) / "baseline") as package:
                identities, times = timer([Side("baseline", source=package), Side("new")], Path(matrix_path),
                                           progress)
        except RuntimeError as error:
            raise InputError(f"--cost-paired {revision}: {error}") from None
    labels = scene_labels(frame)
    stored = {key: (label, setting_label(kh, tol))
              for key, label, kh, tol in zip(frame["run_key"], labels, frame["kh"], frame["tol"], strict=True)}
    outcomes = []
    for index, samples in sorted(times.items()):
        scene, integrator, kh, tol, run_key = identities["new"][index]
        scene, setting = stored.get(run_key, (scene, setting_label(kh, tol)))
        comparison = paired_cost_change(samples["baseline"], samples["new"])
        slower = comparison.changed and comparison.ratio > 1
        outcomes.append(Outcome(bound, str(scene), str(integrator), setting,
                                measured=comparison.ratio, margin=None, passed=not slower,
                                detail=f"×{comparison.ratio:.3f} CPU time against {revision} ({comparison.method}, "
                                       f"p = {comparison.p_value:.2g}, {len(samples['new'])} pairs)"))
    return outcomes
