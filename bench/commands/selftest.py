"""``foucault-bench selftest NAME [--plugin MODULE]``: check an integrator against what it declares
(``bench.gate.conformance``), one line per check.

Exit status 0 when every check holds (skipped checks do not count), 1 when one fails, 2 on bad input: an
unknown integrator, or a plug-in module that does not import or registers no integrator.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.validation import suggestion


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = ("Checks, one line each: the declared order on every model (fixed-step methods), bounded "
                     "just below and diverged just above a declared stability limit, counters, turning points, "
                     "and a divergence and a failure returned as rows. Exit status 0 when all hold, 1 when one "
                     "fails, 2 on bad input.")
    parser.add_argument("name", metavar="NAME", help="the registered name of the integrator to check")
    parser.add_argument("--plugin", metavar="MODULE", action="append", default=[],
                        help="import MODULE first (it registers the integrator); looked up in the current "
                             "directory, then on the Python path; may be repeated")


def load_plugin(module_name: str) -> list[str]:
    """Import ``module_name`` (the current directory first on the path) and return the integrators whose
    class lives in it; ``InputError`` if it does not import or registers none."""
    from foucault_bench.integrators import REGISTRY

    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    try:
        importlib.import_module(module_name)
    except Exception as error:  # the plug-in's own failure is bad input here, reported in one line
        raise InputError(f"--plugin: cannot import {module_name!r}: {type(error).__name__}: {error}") from None
    names = sorted(name for name, integrator in REGISTRY.items()
                   if type(integrator).__module__ == module_name
                   or type(integrator).__module__.startswith(module_name + "."))
    if not names:
        raise InputError(f"--plugin: module {module_name!r} registers no integrator "
                         "(decorate the class with foucault_bench.integrators.register)")
    return names


def main(args: argparse.Namespace) -> int:
    from foucault_bench.bench.gate.conformance import iter_checks
    from foucault_bench.integrators import REGISTRY

    for module_name in args.plugin:
        load_plugin(module_name)
    if args.name not in REGISTRY:
        raise InputError(f"unknown integrator {args.name!r}{suggestion(args.name, REGISTRY)}; "
                         f"known integrators: {', '.join(sorted(REGISTRY))}")
    checks = []
    for check in iter_checks(REGISTRY[args.name]):
        print(f"{check.label:4s}  {check.name}: {check.detail}", flush=True)
        checks.append(check)
    failed = sum(check.holds is False for check in checks)
    skipped = sum(check.holds is None for check in checks)
    print(f"{args.name}: {len(checks) - failed - skipped} hold, {failed} failed, {skipped} skipped")
    return 1 if failed else 0
