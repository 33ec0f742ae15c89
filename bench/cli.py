"""The ``foucault-bench`` command line: one sub-command per module of ``bench.commands``, imported only when used.

Each command module provides ``add_arguments(parser)`` and ``main(args) -> int`` (``bench.commands``). Bad input
raises ``bench.errors.InputError``, which is printed as one line per problem with exit status 2 and no traceback;
so is an SQLite error (a damaged database; the results store turns its own into ``InputError`` naming the file).
A matrix run stopped by its Dask cluster (``bench.errors.RunInterrupted``) exits with 75, SIGINT with 130,
SIGTERM during a matrix run with 143, and a closed output pipe ends quietly with 141 (128 + SIGPIPE). A full disk
(``bench.errors.is_full_disk``) is one line with exit status 2: outputs are written so that the old ones stay
whole (``bench.atomic``) and stored rows stay stored.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys

from foucault_bench.bench.commands import COMMANDS
from foucault_bench.bench.errors import InputError, RunInterrupted, database_error_types, is_full_disk


def _module(name: str):
    return importlib.import_module(f"foucault_bench.bench.commands.{COMMANDS[name][0]}")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser_for(argv)
    args = parser.parse_args(argv)
    try:
        if problems := empty_values(argv):
            raise InputError(problems)
        status = int(_module(args.command).main(args) or 0)
        sys.stdout.flush()  # here, so that a closed pipe is reported below and not at exit
        return status
    except InputError as error:
        for problem in error.problems:
            print(f"foucault-bench {args.command}: error: {problem}", file=sys.stderr)
        return 2
    except database_error_types() as error:  # an SQLite error outside the results store's own reads and writes
        cause = error.__cause__ if error.__cause__ is not None else error
        if is_full_disk(cause):
            return _full_disk(args.command, cause)
        text = str(cause).splitlines()[0] if str(cause) else type(cause).__name__
        print(f"foucault-bench {args.command}: error: SQLite: {text}", file=sys.stderr)
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
    except Exception as error:
        if not is_full_disk(error):
            raise
        return _full_disk(args.command, error)


def empty_values(argv: list[str]) -> list[str]:
    """One problem per empty argument (``--csv ""``, ``--csv=``): no option takes an empty text, and a path given
    empty would otherwise be read as the current folder or as the option left out."""
    problems = []
    for position, token in enumerate(argv):
        option, equals, value = token.partition("=")
        if token.startswith("--") and equals and not value:
            problems.append(f"{option}: an empty value; give one")
        elif token == "":
            before = argv[position - 1] if position else ""
            named = before if before.startswith("-") and "=" not in before else "an argument"
            problems.append(f"{named}: an empty value; give one")
    return problems


def _full_disk(command: str, error: BaseException) -> int:
    print(f"foucault-bench {command}: error: the disk is full ({error}): free some space and run it "
          "again; what was written or stored before is unchanged", file=sys.stderr)
    return 2


def build_parser_for(argv: list[str]) -> argparse.ArgumentParser:
    """The parser with only the chosen sub-command's arguments loaded."""
    parser = argparse.ArgumentParser(
        prog="foucault-bench",
        description="Verification and benchmark suite for ODE integrators on the Foucault pendulum. "
        "Latitudes are geographic (φ, degrees north); the textbook precession is −Ω_E sin φ, "
        "counter-clockwise about local up positive.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    chosen = argv[0] if argv else None
    for name, (_, help_text) in COMMANDS.items():
        command_parser = sub.add_parser(name, help=help_text, description=help_text)
        if name == chosen:
            _module(name).add_arguments(command_parser)
    return parser


def entry() -> None:
    """The ``foucault-bench`` console script: ``main``, then an exit without the interpreter's finalization.

    Every command has closed what it wrote (databases, files, worker processes) when ``main`` returns; what the
    finalization would still do is tear down the numerical libraries, 0.4-0.8 s after a ``run`` on a 2-core
    machine (bench/PERF.md "Start-up"). ``main`` itself returns normally, for callers in the same process."""
    status = main()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (e.g. `| head`): nothing more can be written anyway
            pass
    os._exit(status)


if __name__ == "__main__":
    entry()
