"""The integrator registry: name → integrator instance, filled by discovery.

* **Built-in integrators** are found, not listed: importing ``foucault_bench.integrators`` imports every module
  of its ``methods`` sub-package (``discover_built_ins``), one module per method, whose classes carry
  ``@register``; the framework modules one level up (``base``, ``fixed_step``, ``adaptive``, ``tableau``, ...)
  register nothing. Keep module imports cheap: import heavy libraries inside the functions that need them.
* **Plug-ins** come from the entry-point group ``foucault_bench.integrators`` (each entry point names a module
  or ``module:Class`` to import; ``load_entry_point_plugins``), or from a module imported before running (a
  matrix's ``plugins = [...]``, ``foucault-bench selftest NAME --plugin MODULE``).

``is_built_in`` tells the two apart by the module the integrator's class lives in, so that the project's own
assertions about built-in matrices and declared facts never depend on what else is installed.
"""

from __future__ import annotations

import importlib
import math
import pkgutil
import warnings
from importlib.metadata import entry_points
from typing import TypeVar

from foucault_bench.integrators.base import Integrator

REGISTRY: dict[str, Integrator] = {}
ENTRY_POINT_GROUP = "foucault_bench.integrators"
BUILT_IN_PACKAGE = __name__.rpartition(".")[0]
"""The package of the built-in integrators and their framework (``foucault_bench.integrators``)."""

METHODS_PACKAGE = BUILT_IN_PACKAGE + ".methods"
"""The sub-package whose modules are the built-in methods, one module each (``foucault_bench.integrators.methods``)."""

ENTRY_POINT_MODULES: list[str] = []
"""Modules loaded from entry points, in load order (their sources enter the code version of every run)."""

ENTRY_POINT_ERRORS: dict[str, str] = {}
"""Entry point name → why it could not be loaded (a broken plug-in must not break the suite)."""

IntegratorClass = TypeVar("IntegratorClass", bound=type[Integrator])


def declaration_problems(cls: type[Integrator]) -> list[str]:
    """What is missing or malformed in the facts ``cls`` declares (``Integrator``'s class attributes)."""
    problems = [f"missing class attribute {attribute!r}" for attribute in
                ("name", "family", "order", "adaptive", "reference") if not hasattr(cls, attribute)]
    if problems:
        return problems
    if not (isinstance(cls.name, str) and cls.name.isidentifier()):
        problems.append(f"name must be an identifier-like string, got {cls.name!r}")
    if not (isinstance(cls.family, str) and cls.family):
        problems.append(f"family must be a non-empty string, got {cls.family!r}")
    if not isinstance(cls.adaptive, bool):
        problems.append(f"adaptive must be True or False, got {cls.adaptive!r}")
    for attribute in ("order", "stages"):
        value = getattr(cls, attribute, None)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
            problems.append(f"{attribute} must be a positive integer or None, got {value!r}")
    limit = cls.stability_limit_kh
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, (int, float))
                              or not math.isfinite(limit) or limit <= 0):
        problems.append(f"stability_limit_kh must be a finite number > 0 or None, got {limit!r}")
    if limit is not None and cls.adaptive is True:
        problems.append("stability_limit_kh applies to fixed-step methods only (adaptive ones choose their steps)")
    return problems


def register(cls: IntegratorClass) -> IntegratorClass:
    """Class decorator: check the declared facts and add one instance of ``cls`` under ``cls.name``."""
    problems = declaration_problems(cls)
    if problems:
        raise TypeError(f"{cls.__name__}: {'; '.join(problems)}")
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


def is_built_in(integrator: Integrator | str) -> bool:
    """Whether ``integrator`` (an instance or a registered name) is one of the package's own."""
    instance = get_integrator(integrator) if isinstance(integrator, str) else integrator
    return type(instance).__module__.startswith(BUILT_IN_PACKAGE + ".")


def built_in_names() -> list[str]:
    """Sorted names of the registered built-in integrators."""
    return sorted(name for name, integrator in REGISTRY.items() if is_built_in(integrator))


def discover_built_ins() -> None:
    """Import every module of ``foucault_bench.integrators.methods`` (each registers the methods it defines)."""
    package = importlib.import_module(METHODS_PACKAGE)
    for module in pkgutil.iter_modules(package.__path__, METHODS_PACKAGE + "."):
        if not module.name.rpartition(".")[2].startswith("_"):
            importlib.import_module(module.name)


def load_entry_point_plugins() -> None:
    """Import every plug-in advertised under the ``foucault_bench.integrators`` entry-point group.

    A plug-in that fails to import is recorded in ``ENTRY_POINT_ERRORS`` with a one-line warning, and the
    rest of the suite keeps working."""
    for entry in entry_points(group=ENTRY_POINT_GROUP):
        try:
            entry.load()
        except Exception as error:  # someone else's broken package must not break every command
            ENTRY_POINT_ERRORS[entry.name] = f"{type(error).__name__}: {error}"
            warnings.warn(f"integrator plug-in {entry.name!r} ({entry.value}) could not be loaded: "
                          f"{ENTRY_POINT_ERRORS[entry.name]}", RuntimeWarning, stacklevel=2)
            continue
        if entry.module not in ENTRY_POINT_MODULES:
            ENTRY_POINT_MODULES.append(entry.module)
