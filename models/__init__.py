"""Foucault-pendulum models: a registry from name to ``Model``, filled by discovery.

Every module of this package that defines a module-level ``MODEL`` (a ``models.base.Model``) is a model: it
is found when the package is imported, no list to edit (models/README.md "Adding a model"). ``MODELS`` holds
them simplest first (by their place in the hierarchy that ``Model.refines`` declares, then by name);
``simpler_models`` and ``richer_models`` walk that hierarchy for the adequacy study.
"""

from __future__ import annotations

import importlib
import pkgutil

from foucault_bench.models.base import STATE_NAMES, Model
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S, PendulumParameters


def _discover() -> dict[str, Model]:
    found: dict[str, Model] = {}
    for module in pkgutil.iter_modules(__path__, __name__ + "."):
        if module.name.rpartition(".")[2].startswith("_"):
            continue
        model = getattr(importlib.import_module(module.name), "MODEL", None)
        if isinstance(model, Model):
            if model.name in found:
                raise ValueError(f"two models are named {model.name!r} ({module.name} and another module)")
            found[model.name] = model
    for model in found.values():
        unknown = [name for name in model.refines if name not in found]
        if unknown:
            raise ValueError(f"model {model.name!r} refines unknown model(s) {', '.join(map(repr, unknown))}")
    depth = {name: len(_ancestors(name, found)) for name in found}
    return {name: found[name] for name in sorted(found, key=lambda name: (depth[name], name))}


def _ancestors(name: str, models: dict[str, Model], seen: tuple[str, ...] = ()) -> set[str]:
    if name in seen:
        raise ValueError(f"the models' refines declarations form a cycle through {name!r}")
    result: set[str] = set()
    for parent in models[name].refines:
        result |= {parent} | _ancestors(parent, models, (*seen, name))
    return result


MODELS: dict[str, Model] = _discover()


def get_model(name: str) -> Model:
    """The registered model called ``name``; ``KeyError`` lists the known ones."""
    try:
        return MODELS[name]
    except KeyError:
        raise KeyError(f"unknown model {name!r}; known models: {', '.join(MODELS)}") from None


def simpler_models(name: str) -> tuple[str, ...]:
    """Every model that ``name`` refines, directly or through others, simplest first."""
    ancestors = _ancestors(name, MODELS)
    return tuple(other for other in MODELS if other in ancestors)


def richer_models(name: str) -> tuple[str, ...]:
    """Every model that refines ``name``, directly or through others, simplest first."""
    return tuple(other for other in MODELS if name in _ancestors(other, MODELS))


__all__ = ["MODELS", "Model", "PendulumParameters", "SIDEREAL_EARTH_RATE_RAD_S", "STATE_NAMES", "get_model",
           "richer_models", "simpler_models"]
