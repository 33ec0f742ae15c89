"""``foucault-bench bisect``: the first commit between two revisions where one run's verdict changed."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--good", required=True, metavar="REV", help="a revision with the old verdict")
    parser.add_argument("--bad", required=True, metavar="REV", help="a later revision with the new verdict")
    parser.add_argument("--scene", required=True, metavar="S", help="the scene of the run (a built-in name)")
    parser.add_argument("--integrator", required=True, metavar="I", help="the integrator of the run")
    setting = parser.add_mutually_exclusive_group(required=True)
    setting.add_argument("--kh", type=float, metavar="X", help="the fixed step k·h of the run")
    setting.add_argument("--tol", type=float, metavar="X", help="the tolerance of the run")
    parser.add_argument("--verdict", required=True, metavar="V",
                        help="the results column compared bit for bit (e.g. precession_rate_ref_error)")
    parser.add_argument("--repo", type=Path, default=Path("."), metavar="DIR",
                        help="the git repository (default: the current folder)")


def main(args: argparse.Namespace) -> int:
    import math
    import sys

    from foucault_bench.bench.errors import InputError
    from foucault_bench.bench.history.bisect import Configuration, bisect
    from foucault_bench.bench.history.changes import ACCURACY_COLUMNS
    from foucault_bench.bench.validation import git_repository_problem, suggestion

    problems = []
    if args.verdict not in ACCURACY_COLUMNS:
        problems.append(f"--verdict {args.verdict!r}: not an accuracy column{suggestion(args.verdict, ACCURACY_COLUMNS)}")
    for option, value in (("--kh", args.kh), ("--tol", args.tol)):
        if value is not None and not (math.isfinite(value) and value > 0):
            problems.append(f"{option} must be a finite number > 0, got {value:g}")
    if (problem := git_repository_problem(args.repo)) is not None:
        problems.append(problem)
    if problems:
        raise InputError(problems)
    configuration = Configuration(args.scene, args.integrator, args.verdict, kh=args.kh, tol=args.tol)
    answer = bisect(args.repo.resolve(), args.good, args.bad, configuration,
                    progress=lambda line: print(line, file=sys.stderr))
    print(f"first commit with another {args.verdict}: {answer.first_changed}")
    print(f"  before ({answer.last_unchanged[:10]}): {answer.value_before!r}")
    print(f"  after  ({answer.first_changed[:10]}): {answer.value_after!r}")
    print(f"  {len(answer.tested)} commit(s) run, {len(answer.skipped)} skipped")
    for commit, why in answer.skipped.items():
        print(f"  skipped {commit[:10]}: {why}")
    return 0
