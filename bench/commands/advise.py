"""``foucault-bench advise``: the cheapest integrator and setting for a scene and a target error (bench.advise).

    foucault-bench advise --scene NAME --target METRIC=VALUE [--db DB] [--matrix FILE] [--json] [--jobs N]
    foucault-bench advise --scene ENSEMBLE --target METRIC=VALUE --worst [--db DB] [--matrix FILE] [--json]

Bad input (unknown scene or metric, a target that is not a number > 0, a metric that does not exist for the
scene's model, a missing database with ``--no-search``, a damaged database) is exit status 2 with one line per
problem; no run meeting the target even after the search is exit status 1. With ``--no-search`` the database is
opened read-only and must exist. With ``--worst`` the scene is an ensemble, the answer is for each setting's worst
member (``bench.advise.worst``) from the stored rows only, and the database is opened read-only.
"""

from __future__ import annotations

import argparse
import sys

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.run.store import DEFAULT_DB


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", required=True, help="a built-in scene or one defined in --matrix FILE")
    parser.add_argument("--target", required=True, metavar="METRIC=VALUE",
                        help="the error to reach, e.g. reference_error=1e-6; metrics: reference_error, "
                             "precession_rate_ref_error, energy_max_rel_error, energy_drift_per_s, "
                             "analytic_gap_exact")
    parser.add_argument("--db", default=str(DEFAULT_DB),
                        help="results database to read, and to store the search's runs in (default: %(default)s)")
    parser.add_argument("--matrix", metavar="FILE", help="a matrix file whose [scene.NAME] tables define scenes")
    parser.add_argument("--json", action="store_true", help="print the answer as one JSON object")
    parser.add_argument("--jobs", type=int, default=None,
                        help="worker processes for the search when no stored run meets the target "
                             "(default: the cores available)")
    parser.add_argument("--no-search", action="store_true",
                        help="answer from the stored runs only, never run a search (the database is only read, "
                             "and must exist)")
    parser.add_argument("--worst", action="store_true",
                        help="--scene names an ensemble: rank each integrator and setting by its worst member "
                             "(stored rows only, no search)")


def main(args: argparse.Namespace) -> int:
    from foucault_bench.bench.advise import advise, metric_problem, parse_target, render_json, render_text, \
        resolve_scene
    from foucault_bench.bench.provenance import available_cores
    from foucault_bench.bench.run.store import ResultsStore

    target, problems = parse_target(args.target)
    if args.worst:
        return _worst(args, target, problems)
    scene, scene_problems = resolve_scene(args.scene, args.matrix)
    problems += scene_problems
    if args.jobs is not None and args.jobs < 1:
        problems.append(f"--jobs must be at least 1, got {args.jobs}")
    if scene is not None and target is not None and (problem := metric_problem(scene, target)):
        problems.append(problem)
    if problems:
        raise InputError(problems)
    assert scene is not None and target is not None  # each comes with a problem when it is None
    jobs = None if args.no_search else (args.jobs or available_cores())
    with ResultsStore(args.db, create=not args.no_search) as store:
        answer = advise(store, scene, target, search_jobs=jobs, progress=not args.json and sys.stderr.isatty())
    print(render_json(answer) if args.json else render_text(answer))
    return 0 if answer.recommended is not None else 1


def _worst(args: argparse.Namespace, target, problems: list[str]) -> int:
    """``advise --worst``: the answer for the ensemble's worst members (``bench.advise.worst``)."""
    from foucault_bench.bench.advise import metric_problem, render_json, render_text
    from foucault_bench.bench.advise.target import resolve_ensemble
    from foucault_bench.bench.advise.worst import advise_worst
    from foucault_bench.bench.run.store import ResultsStore

    members, member_problems = resolve_ensemble(args.scene, args.matrix)
    problems += member_problems
    if members and target is not None and (problem := metric_problem(members[0], target)):
        problems.append(problem)
    if problems:
        raise InputError(problems)
    assert target is not None
    with ResultsStore(args.db, create=False) as store:
        answer = advise_worst(store, args.scene, members, target)
    print(render_json(answer) if args.json else render_text(answer))
    return 0 if answer.recommended is not None else 1
