"""The ``foucault-bench`` command line: one sub-command per module, imported only when used.

Each sub-command module provides ``add_arguments(parser)`` and ``main(args) -> int``. Bad input raises
``bench.errors.InputError``, which is printed as one line per problem with exit status 2 and no traceback.
A matrix run stopped by its Dask cluster (``bench.errors.RunInterrupted``) exits with 75, SIGINT with 130,
SIGTERM during a matrix run with 143, and a closed output pipe ends quietly with 141 (128 + SIGPIPE).
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys

from foucault_bench.bench.errors import InputError, RunInterrupted

COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("foucault_bench.bench.commands.run", "run a benchmark matrix and store one row per run"),
    "results": ("foucault_bench.bench.commands.results", "list, export and compare stored runs"),
    "check": ("foucault_bench.bench.gate.check", "check stored or fresh results against a thresholds file (CI gate)"),
    "selftest": ("foucault_bench.bench.commands.selftest", "check an integrator (built-in or plug-in) against its declared facts"),
    "perf": ("foucault_bench.bench.perf", "measure the suite's own speed against C loops and bare libraries"),
    "advise": ("foucault_bench.bench.commands.advise", "the cheapest integrator and setting for a scene and a target error"),
    "report": ("foucault_bench.reports.build", "build the HTML/Markdown report from a results database"),
    "seed": ("foucault_bench.reports.seed", "reproduce and correct the seed note's figures"),
    "simulate": ("foucault_bench.reports.simulate", "interactive simulation (or --save an animation)"),
}


def _module(module_name: str):
    return importlib.import_module(module_name)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser_for(argv)
    args = parser.parse_args(argv)
    try:
        status = int(_module(args._module).main(args) or 0)
        sys.stdout.flush()  # here, so that a closed pipe is reported below and not at exit
        return status
    except InputError as error:
        for problem in error.problems:
            print(f"foucault-bench {args.command}: error: {problem}", file=sys.stderr)
        return 2
    except RunInterrupted as error:
        print(f"foucault-bench {args.command}: interrupted: {error}", file=sys.stderr)
        return error.exit_status
    except KeyboardInterrupt as error:  # SIGINT (130), or SIGTERM while a matrix runs (143)
        print("interrupted", file=sys.stderr)
        return getattr(error, "exit_status", 130)
    except BrokenPipeError:  # the reader went away (`foucault-bench results | head`): end quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # Python docs, "Note on SIGPIPE": no second error at exit
        return 128 + signal.SIGPIPE


def build_parser_for(argv: list[str]) -> argparse.ArgumentParser:
    """The parser with only the chosen sub-command's arguments loaded (all of them for a top-level --help)."""
    parser = argparse.ArgumentParser(
        prog="foucault-bench",
        description="Verification and benchmark suite for ODE integrators on the Foucault pendulum. "
        "Latitudes are geographic (φ, degrees north); the textbook precession is −Ω_E sin φ, "
        "counter-clockwise about local up positive.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    chosen = argv[0] if argv else None
    for name, (module_name, help_text) in COMMANDS.items():
        command_parser = sub.add_parser(name, help=help_text, description=help_text)
        command_parser.set_defaults(_module=module_name)
        if name == chosen:
            _module(module_name).add_arguments(command_parser)
    return parser


if __name__ == "__main__":
    sys.exit(main())
