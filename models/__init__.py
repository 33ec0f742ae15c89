"""Foucault-pendulum models (models/README.md "The three models"): a registry from name to ``Model``.

Add a model by writing a module with a ``free_force`` and an ``energy`` source and a ``MODEL`` object, and
listing it here; every integrator then runs it.
"""

from foucault_bench.models.base import STATE_NAMES, Model
from foucault_bench.models.linear import MODEL as LINEAR
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S, PendulumParameters
from foucault_bench.models.seed_planar import MODEL as SEED_PLANAR
from foucault_bench.models.spherical import MODEL as SPHERICAL

MODELS: dict[str, Model] = {model.name: model for model in (LINEAR, SEED_PLANAR, SPHERICAL)}


def get_model(name: str) -> Model:
    """The registered model called ``name``; ``KeyError`` lists the known ones."""
    try:
        return MODELS[name]
    except KeyError:
        raise KeyError(f"unknown model {name!r}; known models: {', '.join(MODELS)}") from None


__all__ = ["MODELS", "Model", "PendulumParameters", "SIDEREAL_EARTH_RATE_RAD_S", "STATE_NAMES", "get_model"]
