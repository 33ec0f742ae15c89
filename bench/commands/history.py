"""``foucault-bench history``: every stored run's verdicts and cost across code revisions, and what changed."""

from __future__ import annotations

import argparse
from pathlib import Path

from foucault_bench.bench.run.store import DEFAULT_DB  # the store module imports no numerical library


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--db", type=Path, default=DEFAULT_DB, help=f"results database (default {DEFAULT_DB})")
    parser.add_argument("--scene", action="append", default=[], metavar="S",
                        help="only this scene (name, or the label shown for a name with two physics); repeatable")
    parser.add_argument("--integrator", action="append", default=[], metavar="I",
                        help="only this integrator; repeatable")
    parser.add_argument("--repo", type=Path, default=None, metavar="DIR",
                        help="git repository whose commit order orders the revisions (default: the current "
                             "folder if it is one; else revisions are ordered by time)")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="also write the history page (history.html, changes.csv, history.csv) into this "
                             "folder, replaced whole; an existing folder must be an earlier history, report or "
                             "seed folder, or empty")
    parser.add_argument("--force", action="store_true",
                        help="replace an existing --out folder that was not written by foucault-bench")


def main(args: argparse.Namespace) -> int:
    from tabulate import tabulate

    from foucault_bench.bench.commands.outputs import output_folder
    from foucault_bench.bench.errors import InputError
    from foucault_bench.bench.history.changes import changes_frame
    from foucault_bench.bench.history.load import load_history
    from foucault_bench.bench.validation import git_repository_problem

    if args.repo is not None and (problem := git_repository_problem(args.repo)) is not None:
        raise InputError(problem)
    if args.out is not None:
        output_folder(args.out, "--out", force=args.force, inputs={"--db": args.db, "--repo": args.repo})
    repository = args.repo if args.repo is not None else Path.cwd()
    history = load_history(args.db, scenes=args.scene, integrators=args.integrator, repository=repository)
    runs = history.rows["run"].nunique()
    print(f"{len(history.revisions)} revision(s) ordered by {history.ordered_by}, {runs} run(s): "
          f"{len(history.changes)} change(s)")
    for number, revision in enumerate(history.revisions, start=1):
        print(f"  {number}. {revision.label} ({len(revision.matrix_ids)} matrix run(s), first {revision.started_utc})")
    frame = changes_frame(history.changes)
    if not frame.empty:
        shown = frame[["before_revision", "after_revision", "scene", "integrator", "setting", "kind", "column",
                       "before", "after", "detail"]]
        print(tabulate(shown.values.tolist(), headers=list(shown.columns), floatfmt=".6g", disable_numparse=True))
    if args.out is not None:
        from foucault_bench.bench.atomic import replacing_folder
        from foucault_bench.reports.history_page import write_history

        with replacing_folder(args.out, "--out", "history") as staging:
            write_history(history, staging)
        print(f"history page: {args.out / 'history.html'}")
    return 0
