"""Which models a test runs a scheme on, where running every scheme on every model would compile each scheme once
per model (the compilations are most of the suite's time) and the models differ only in force terms that every
scheme reaches the same way.

``refinement_leaves``: the models no other model refines. A refinement, at its example parameters
(``Model.example_parameters``), carries every force term of the models it refines, so the leaves hold between them
every force term, geometry and kind of force of the registry (tests/test_selftest.py checks it).
``LEAVES_AND_LINEAR``: the leaves and the linear model, which the conformance checks compile anyway (counters,
stability).
"""

from __future__ import annotations

from foucault_bench.models import MODELS


def refinement_leaves() -> tuple[str, ...]:
    """The names of the models no other model of ``MODELS`` refines, in registry order."""
    refined = {parent for model in MODELS.values() for parent in model.refines}
    return tuple(name for name in MODELS if name not in refined)


LEAVES_AND_LINEAR = ("linear", *refinement_leaves())
