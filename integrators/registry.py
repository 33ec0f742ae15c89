"""The integrator registry: name → integrator instance.

``register`` is a class decorator; the built-in integrators register themselves when ``integrators`` is
imported, and third-party ones through the entry-point group ``foucault_bench.integrators`` (each entry point
names a module or class to import) or by importing their module before running.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import TypeVar

from foucault_bench.integrators.base import Integrator

REGISTRY: dict[str, Integrator] = {}
ENTRY_POINT_GROUP = "foucault_bench.integrators"

IntegratorClass = TypeVar("IntegratorClass", bound=type)


def register(cls: IntegratorClass) -> IntegratorClass:
    """Class decorator: add one instance of ``cls`` to the registry under ``cls.name``."""
    for attribute in ("name", "family", "order", "adaptive", "reference"):
        if not hasattr(cls, attribute):
            raise TypeError(f"{cls.__name__} must declare the class attribute {attribute!r}")
    if cls.name in REGISTRY and type(REGISTRY[cls.name]) is not cls:
        raise ValueError(f"an integrator named {cls.name!r} is already registered ({type(REGISTRY[cls.name]).__name__})")
    REGISTRY[cls.name] = cls()
    return cls


def unregister(name: str) -> None:
    """Remove ``name`` from the registry (tests register mutated integrators and remove them again)."""
    REGISTRY.pop(name, None)


def get_integrator(name: str) -> Integrator:
    """The registered integrator called ``name``; ``KeyError`` lists the known ones."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown integrator {name!r}; known integrators: {', '.join(sorted(REGISTRY))}") from None


def load_plugins() -> None:
    """Import every integrator advertised under the ``foucault_bench.integrators`` entry-point group."""
    for entry in entry_points(group=ENTRY_POINT_GROUP):
        entry.load()
