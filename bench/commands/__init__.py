"""The sub-commands of the ``foucault-bench`` command line: one module each, with all their argument parsing.

Each module provides ``add_arguments(parser)`` (argparse only: importing a command module loads no numerical
library, so ``--help`` is fast) and ``main(args) -> int`` (which imports the library modules it calls). The
library modules (``bench.run``, ``bench.gate``, ``bench.perf``, ``reports``) take plain values and never parse
arguments. ``COMMANDS`` is the one list of commands ``bench.cli`` builds its parser from.
"""

from __future__ import annotations

COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("run", "run a benchmark matrix and store one row per run"),
    "results": ("results", "list, export and compare stored runs"),
    "check": ("check", "check stored or fresh results against a thresholds file (CI gate)"),
    "selftest": ("selftest", "check an integrator (built-in or plug-in) against its declared facts"),
    "perf": ("perf", "measure the suite's own speed against C loops and bare libraries"),
    "advise": ("advise", "the cheapest integrator and setting for a scene and a target error"),
    "history": ("history", "each stored run's verdicts and cost across code revisions, and what changed"),
    "bisect": ("bisect", "the first commit between two revisions that changed one run's verdict"),
    "report": ("report", "build the HTML/Markdown report from a results database"),
    "seed": ("seed", "reproduce and correct the seed note's figures"),
    "simulate": ("simulate", "interactive simulation (or --save an animation)"),
}
"""Command name → (module in this package, one-line help)."""
