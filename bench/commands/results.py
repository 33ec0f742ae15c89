"""``foucault-bench results``: list stored matrix runs, export rows, compare two matrix runs (bench.run.store)."""

from __future__ import annotations

import argparse
import sys

from foucault_bench.bench.atomic import replacing_file
from foucault_bench.bench.commands.outputs import distinct_from_inputs, output_file
from foucault_bench.bench.errors import InputError, require_extra
from foucault_bench.bench.run.store import DEFAULT_DB


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--db", default=str(DEFAULT_DB), help="results database (default: %(default)s)")
    chosen = parser.add_mutually_exclusive_group()
    chosen.add_argument("--matrix-id", metavar="ID",
                        help="the matrix run to show or export: an id or a unique prefix (default: the latest)")
    chosen.add_argument("--all", action="store_true", help="export the rows of every matrix run")
    parser.add_argument("--csv", metavar="FILE", help="write the selected run rows to a CSV file")
    parser.add_argument("--parquet", metavar="FILE",
                        help="write the selected run rows to a Parquet file (needs the 'parquet' extra)")
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"),
                        help="compare two matrix runs: accuracy columns must match bit for bit (exit status 1 "
                             "if not); costs are shown as ratios B/A")


def main(args: argparse.Namespace) -> int:
    exports = {"--csv": args.csv, "--parquet": args.parquet}
    distinct_from_inputs(exports, {"--db": args.db}, databases=("--db",))
    if args.parquet:
        require_extra("pyarrow", "parquet", "--parquet")
    import pandas as pd

    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.run.summary import summary_text

    if args.compare and (args.csv or args.parquet or args.all or args.matrix_id):
        raise InputError("--compare takes two matrix ids and no other selection or export option")
    for option, path in exports.items():
        if path:
            output_file(path, option)
    with ResultsStore(args.db, create=False) as store:
        if args.compare:
            return _compare(store, *args.compare)
        rows = store.frame(args.matrix_id, all_runs=args.all)
        for option, path, write in (("--csv", args.csv, rows.to_csv), ("--parquet", args.parquet, rows.to_parquet)):
            if path:
                with replacing_file(path, option) as temporary:
                    write(temporary, index=False)
                print(f"wrote {len(rows)} rows to {path}", file=sys.stderr)
        if args.csv or args.parquet:
            return 0
        runs = store.matrix_runs()[["matrix_id", "matrix_name", "status", "started_utc", "finished_utc",
                                    "runs_planned", "rows_stored", "ok", "diverged", "failed", "timeout", "host",
                                    "git_commit"]]
        with pd.option_context("display.width", 200, "display.max_columns", None):
            print(runs.to_string(index=False, na_rep="–"))
        matrix_id = store.resolve_matrix_id(args.matrix_id)
        print(f"\nmatrix run {matrix_id}:")
        print(summary_text(store.records(matrix_id)))
        _print_ensembles(store.frame(matrix_id))
    return 0


def _print_ensembles(rows) -> None:
    """The ensemble summary of the matrix run's member rows, per metric (nothing without members)."""
    from foucault_bench.bench.ensembles.summary import SUMMARY_METRICS, summary_text as ensemble_text

    for metric in SUMMARY_METRICS:
        text = ensemble_text(rows, metric)
        if text:
            print(f"\n{text}")


def _compare(store, first: str, second: str) -> int:
    from foucault_bench.bench.run.compare import compare_runs, scene_differences

    id_a, id_b = store.resolve_matrix_id(first), store.resolve_matrix_id(second)
    frame_a, frame_b = store.frame(id_a), store.frame(id_b)
    mismatches, costs, unmatched = compare_runs(frame_a, frame_b)
    code = store.matrix_runs().set_index("matrix_id")["code_version"]
    only = {side: sum(other == side for other, _ in unmatched) for side in "AB"}
    print(f"A = {id_a}, B = {id_b}: {len(costs)} runs in both, {only['A']} only in A, {only['B']} only in B")
    if code[id_a] != code[id_b]:
        print(f"note: different code versions (A {code[id_a]}, B {code[id_b]}): differences may be real changes")
    differing = scene_differences(frame_a, frame_b)
    for reason in differing.values():
        print(f"note: {reason}")
    if costs.empty:
        print("nothing to compare: the two matrix runs share no run")
        print(unmatched_text(unmatched, frame_a, frame_b, set(differing)))
        return 1
    print(cost_ratio_text(costs))
    if mismatches.empty:
        print(f"\naccuracy columns: identical bit for bit in all {len(costs)} shared runs")
    else:
        print(f"\naccuracy columns: {len(mismatches)} MISMATCH(ES) (values as Python's repr: the shortest text "
              "that reads back as the same double, so two values shown alike are equal)")
        shown = mismatches.assign(a=mismatches["a"].map(_exact), b=mismatches["b"].map(_exact))
        print(shown.to_string(index=False))
    print(unmatched_text(unmatched, frame_a, frame_b, set(differing)))
    return 0 if mismatches.empty and not unmatched else 1


def _exact(value) -> str:
    """A stored value as text that tells every two doubles apart (``repr`` of the float; missing as NULL)."""
    import pandas as pd

    if value is None or (not isinstance(value, str) and pd.isna(value)):
        return "NULL"
    return repr(float(value)) if isinstance(value, (int, float)) and not isinstance(value, bool) else str(value)


def unmatched_text(unmatched: list[tuple[str, str]], frame_a, frame_b, differing: set[str]) -> str:
    """The runs in only one matrix run, each with its side; those of a scene whose physics differs between A
    and B (``differing``, named above them) counted per scene and side instead of listed."""
    from foucault_bench.bench.run.compare import run_identity

    scene_of = {}
    for side, frame, other in (("A", frame_a, frame_b), ("B", frame_b, frame_a)):
        scene_of.update({(side, run): scene for run, scene in zip(run_identity(frame, other), frame["scene"],
                                                                  strict=True)})
    counted: dict[tuple[str, str], int] = {}
    lines = []
    for side, run in unmatched:
        scene = scene_of[side, run]
        if scene in differing:
            counted[scene, side] = counted.get((scene, side), 0) + 1
        else:
            lines.append(f"only in {side}: {run}")
    lines += [f"only in {side}: {count} run(s) of scene {scene} (its physics differs from the other side's)"
              for (scene, side), count in sorted(counted.items())]
    return "\n".join(lines)


def cost_ratio_text(costs) -> str:
    """The median cost ratio B/A per integrator over the runs where both costs are finite and positive
    (``compare_runs``), then, per cost, how many runs were left out and why."""
    import numpy as np

    from foucault_bench.bench.run.compare import COST_COLUMNS

    suffix = "_ratio_b_over_a"
    ratios = costs.groupby("integrator")[[f"{column}{suffix}" for column in COST_COLUMNS]].median()
    ratios.columns = [column.removesuffix(suffix) for column in ratios.columns]
    lines = ["", "median cost ratio B/A per integrator (over the runs where both costs are positive; '–': none):",
             ratios.to_string(float_format=lambda value: f"{value:.3g}", na_rep="–")]
    for column in COST_COLUMNS:
        left_out = costs[f"{column}{suffix}"].isna()
        if not left_out.any():
            continue
        cost_a, cost_b = costs.loc[left_out, f"{column}_a"], costs.loc[left_out, f"{column}_b"]
        missing = int((~np.isfinite(cost_a) | ~np.isfinite(cost_b)).sum())
        reasons = [f"{count} {why}" for count, why in (
            (int(left_out.sum()) - missing, "with a cost of 0 or below in A or B"
             + (" (nothing compiled, or a cached compile)" if column == "compile_time_s" else "")),
            (missing, "with no finite cost in A or B (e.g. a failed run)")) if count]
        lines.append(f"{column}: {int(left_out.sum())} of {len(costs)} shared runs left out, {'; '.join(reasons)}: "
                     "a ratio to or of zero says nothing")
    return "\n".join(lines)
