"""``foucault-bench perf``: the suite's own speed against C loops and the bare libraries (``bench.perf``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from foucault_bench.bench.perf import SECTIONS  # the package imports only the standard library


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true",
                        help="a fast subset of each section (shorter runs, fewer repeats, quick matrix only)")
    parser.add_argument("--only", action="append", choices=list(SECTIONS), metavar="SECTION",
                        help=f"run only this section (repeatable): {', '.join(SECTIONS)}")
    parser.add_argument("--markdown", type=Path, metavar="PATH", help="also write every table as Markdown to PATH")


def main(args: argparse.Namespace) -> int:
    from foucault_bench.bench.commands.outputs import output_file
    from foucault_bench.bench.perf import run

    if args.markdown:
        output_file(args.markdown, "--markdown")  # before minutes of measuring

    return run(args.only or list(SECTIONS), quick=args.quick, markdown_path=args.markdown)
