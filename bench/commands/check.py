"""``foucault-bench check``: the CI gate — a thresholds file checked on stored rows or on a fresh matrix run.

Exit status 0 when every bound holds, 1 when one fails, 2 on bad input (found before any matrix runs), among
it a stored matrix run that is not finished (``--allow-unfinished`` checks its rows anyway). The thresholds file
format is described in ``bench.gate.thresholds``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from foucault_bench.bench.commands import options
from foucault_bench.bench.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--thresholds", required=True, metavar="FILE",
                        help="thresholds TOML file, or a built-in name (default)")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--results", metavar="DB", help="check the rows of a stored matrix run in this database")
    source.add_argument("--matrix", metavar="FILE",
                        help="run this matrix (built-in name or TOML file) and check it (default: the matrix "
                             "named in the thresholds file)")
    parser.add_argument("--matrix-id", metavar="ID",
                        help="with --results: the stored matrix run to check (id or unique prefix; default: latest)")
    parser.add_argument("--allow-unfinished", action="store_true",
                        help="with --results: also check a matrix run that is not finished (status running or "
                             "interrupted: only some of its rows are stored), with a note; without it such a run "
                             "is refused (exit 2)")
    parser.add_argument("--baseline", metavar="DB[:MATRIX_ID]",
                        help="also compare with a finished matrix run of this database (default: its latest): an "
                             "accuracy column that differs fails unless the thresholds file declares it an "
                             "[[expected_change]]")
    parser.add_argument("--cost", action="store_true",
                        help="with --baseline: also fail on a CPU-time slowdown beyond the noise of both runs (costs "
                             "measured at two different times: on a busy machine this over-reports, bench/PERF.md; "
                             "--cost-paired does not)")
    parser.add_argument("--cost-paired", metavar="REV",
                        help="when running a matrix: time every run's solve again, in turn with the code of this git "
                             "revision of --repo (checked out in a temporary git worktree) in one session, and fail "
                             "on a CPU-time slowdown beyond the paired noise; unlike --baseline --cost it stays "
                             "within its noise target on a busy machine (bench/PERF.md)")
    parser.add_argument("--repo", type=Path, default=Path("."), metavar="DIR",
                        help="with --cost-paired: the git repository of this code (default: the current folder)")
    parser.add_argument("--db", metavar="FILE",
                        help="when running a matrix: keep its results in this database (default: a temporary one)")
    parser.add_argument("--jobs", type=int, default=None, help="worker processes when running a matrix "
                                                               "(default: the cores available)")
    parser.add_argument("--format", choices=("text", "markdown"), default="text",
                        help="table format on stdout (markdown for CI job summaries; default: %(default)s)")
    parser.add_argument("--junit", metavar="FILE", help="also write the checks as JUnit XML")
    parser.add_argument("--run-timeout", type=float, default=None, metavar="SECONDS",
                        help="when running a matrix: per-run time limit, at most 1e6 s (default: the matrix's "
                             "[timing] run_timeout_s, else 600 s); a run past it is stored with status timeout")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars while running a matrix")


def main(args: argparse.Namespace) -> int:
    from foucault_bench.bench.gate.evaluate import evaluate
    from foucault_bench.bench.gate.render import junit_xml, render
    from foucault_bench.bench.gate.select import validate_against
    from foucault_bench.bench.gate.thresholds import load_thresholds

    from foucault_bench.bench.atomic import replacing_file
    from foucault_bench.bench.commands.outputs import creatable, distinct_from_inputs, output_file

    # before any work: a bad output path is exit 2, not a gate run lost at the end
    if args.junit:
        output_file(args.junit, "--junit")
    if args.db:
        creatable(args.db, "--db", folder=False)
    thresholds = load_thresholds(args.thresholds)
    if args.matrix_id and not args.results:
        raise InputError("--matrix-id selects a stored run: give it with --results")
    if args.db and args.results:
        raise InputError("--db is where a fresh matrix run is kept; with --results give the database there")
    if args.cost and not args.baseline:
        raise InputError("--cost compares costs with a baseline: give --baseline DB")
    if args.cost_paired and args.results:
        raise InputError("--cost-paired times the matrix's solves beside the revision's code: give --matrix (or "
                         "the thresholds file's matrix), not --results")
    paired_commit = None
    if args.cost_paired:
        from foucault_bench.bench.gate.paired_cost_gate import resolved_revision

        paired_commit = resolved_revision(args.repo, args.cost_paired)
    if args.allow_unfinished and not args.results:
        raise InputError("--allow-unfinished is for a stored matrix run: give it with --results")
    matrix_file = None if args.results else _user_file(args.matrix or thresholds.matrix_to_run())
    baseline_db, baseline_id = (None, None)
    if args.baseline:
        from foucault_bench.bench.gate.baseline import split_baseline

        baseline_db, baseline_id = split_baseline(args.baseline)
    distinct_from_inputs({"--db": args.db, "--junit": args.junit},
                         {"--thresholds": _user_file(args.thresholds), "--results": args.results, "--matrix": matrix_file,
                          "--baseline": baseline_db},
                         databases=("--results", "--baseline"))
    baseline = None
    if baseline_db is not None:
        from foucault_bench.bench.gate.check import stored_rows_for_check

        baseline = stored_rows_for_check(baseline_db, baseline_id, allow_unfinished=False)
    if args.results:
        from foucault_bench.bench.gate.check import stored_rows_for_check

        frame, what = stored_rows_for_check(args.results, args.matrix_id, allow_unfinished=args.allow_unfinished)
    else:
        from foucault_bench.bench.gate.check import run_for_check

        matrix_name = args.matrix or thresholds.matrix_to_run()
        if matrix_name is None:
            raise InputError(f"{thresholds.source} names no matrix: give --results DB or --matrix FILE")
        frame, what = run_for_check(thresholds, matrix_name, db=args.db, jobs=options.jobs(args.jobs),
                                    progress=not args.no_progress, run_timeout_s=args.run_timeout)
    validate_against(thresholds, frame, what=what)
    outcomes = evaluate(thresholds, frame)
    if baseline is not None:
        from foucault_bench.bench.gate.baseline import baseline_outcomes

        baseline_frame, baseline_what = baseline
        outcomes += baseline_outcomes(thresholds, frame, baseline_frame, cost=args.cost,
                                      what=f"the baseline {baseline_what}")
    if paired_commit is not None:
        from foucault_bench.bench.gate.paired_cost_gate import paired_cost_outcomes

        assert matrix_name is not None  # --cost-paired refuses --results: a matrix was run
        first_number = len(thresholds.bounds) + (3 if baseline is not None else 1)  # after --baseline's two

        def progress(line: str) -> None:
            if not args.no_progress:
                print(f"paired: {line}", file=sys.stderr)

        outcomes += paired_cost_outcomes(matrix_name, frame, args.repo, args.cost_paired, paired_commit,
                                         first_number=first_number, progress=progress)
    print(f"checking {thresholds.source} against {what}", file=sys.stderr)
    unbounded = sorted(set(frame["integrator"]) - {outcome.integrator for outcome in outcomes})
    if unbounded:
        print(f"note: {len(unbounded)} integrator(s) of {what} have no bound in {thresholds.source}, so nothing "
              f"checks them: {', '.join(unbounded)}", file=sys.stderr)
    print(render(outcomes, markdown=args.format == "markdown"))
    if args.junit:
        with replacing_file(args.junit, "--junit") as temporary:
            junit_xml(outcomes, suite=f"{thresholds.source} on {what}").write(temporary, encoding="utf-8",
                                                                            xml_declaration=True)
    return 0 if all(outcome.passed for outcome in outcomes) else 1


def _user_file(name: str | None) -> str | None:
    """``name`` when it is a file (a thresholds or matrix file of the user's), None for a built-in name."""
    from pathlib import Path

    return name if name is not None and Path(name).is_file() else None
