"""Provenance: what produced a row — the code version, the git commit, the machine — and the hashes built on it.

* ``code_version``: SHA-256 of the package version and of every source file that determines a row's numbers
  (``NUMBER_SOURCES``, relative to ``PACKAGE_ROOT``) plus the sources of plug-in modules (those a matrix names
  and those the registry loaded from entry points; a plug-in package with all its modules), so that
  ``--resume`` never reuses a row of other code; ``ensemble_code_version`` adds the batch runner's sources
  (``BATCH_SOURCES``) for ensemble members;
* ``source_digest``: the same hash over any list of files (the reference cache keys its files with it);
* ``digest``: a short SHA-256 of plain data (run keys, matrix hashes);
* ``git_commit``, ``cpu_model``, ``package_versions``, ``machine``: the matrix run's provenance record;
  ``available_cores``: the cores this process may use (the default number of workers).

This module imports only the standard library, so that both the matrix reader and the results store use it
without importing each other.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import json
import os
import platform
import socket
import subprocess
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any, Iterable

PACKAGE_ROOT = Path(__file__).resolve().parents[1]
"""The folder holding ``bench/``, ``models/``, ``integrators/``: the repository in a checkout or an editable
install, ``site-packages/foucault_bench`` in a wheel install."""
NUMBER_SOURCES = ("models/*.py", "integrators/*.py", "integrators/methods/*.py", "bench/problems/*.py",
                  "bench/scenes/*.toml",
                  "bench/verdicts/*.py", "bench/run/execute.py", "bench/run/timing.py")
"""Source files (relative to ``PACKAGE_ROOT``) whose contents are part of every run key."""
BATCH_SOURCES = ("bench/run/ensemble_jobs.py",)
"""Source files that also determine the rows of ensemble members, which run as batches (their cost shares):
part of their run keys only (``ensemble_code_version``), so that the other runs' keys do not depend on them."""
PROVENANCE_PACKAGES = ("numpy", "scipy", "numba", "heyoka", "scikit-sundae", "pandas", "distributed")
"""Libraries whose versions each matrix run records."""


def digest(value: Any) -> str:
    """SHA-256 (16 hex digits) of ``value`` as canonical JSON (sorted keys; ``repr`` for other objects)."""
    return hashlib.sha256(json.dumps(value, sort_keys=True, default=repr).encode()).hexdigest()[:16]


def source_digest(salt: str, paths: Iterable[Path]) -> str:
    """SHA-256 (16 hex digits) of ``salt`` and of each file's name and bytes, in the order given."""
    hashed = hashlib.sha256(salt.encode())
    for path in paths:
        hashed.update(path.name.encode())
        hashed.update(path.read_bytes())
    return hashed.hexdigest()[:16]


def package_version() -> str:
    try:
        return version("foucault-bench")
    except PackageNotFoundError:
        return "unknown"


def module_sources(module_name: str) -> list[Path]:
    """The source files of an importable module: its file, or every ``.py`` file of a package (none for
    built-in, frozen or missing modules)."""
    try:
        spec = importlib.util.find_spec(module_name)
    except (ImportError, ValueError):
        return []
    if spec is None or not spec.origin or spec.origin in ("built-in", "frozen"):
        return []
    origin = Path(spec.origin)
    return sorted(origin.parent.rglob("*.py")) if spec.submodule_search_locations else [origin]


def plugin_sources(plugins: Iterable[str] = ()) -> list[Path]:
    """Source files of the named plug-in modules and of the modules the registry loaded from entry points
    (``integrators.registry.ENTRY_POINT_MODULES``), in a stable order, each once."""
    from foucault_bench.integrators.registry import ENTRY_POINT_MODULES  # the integrators are loaded by then

    names = dict.fromkeys([*plugins, *ENTRY_POINT_MODULES])
    return list(dict.fromkeys(path for name in names for path in module_sources(name)))


@functools.lru_cache(maxsize=None)
def code_version(plugins: tuple[str, ...] = ()) -> str:
    """SHA-256 (16 hex digits) of the package version and of every source file that determines a row's
    numbers (``NUMBER_SOURCES``, plus the plug-ins' files, ``plugin_sources``): a stored row is reused by
    ``--resume`` only when none of them changed, committed or not."""
    paths = sorted({path for pattern in NUMBER_SOURCES for path in PACKAGE_ROOT.glob(pattern)})
    return source_digest(package_version(), [*paths, *plugin_sources(plugins)])


@functools.lru_cache(maxsize=None)
def ensemble_code_version(plugins: tuple[str, ...] = ()) -> str:
    """The code version of an ensemble member's run: ``code_version`` and the batch sources (``BATCH_SOURCES``)."""
    return source_digest(code_version(plugins), [PACKAGE_ROOT / path for path in BATCH_SOURCES])


@functools.lru_cache(maxsize=1)
def git_commit() -> str | None:
    """HEAD commit of the source tree the package is imported from, with ``+dirty`` for uncommitted
    changes to tracked files; ``None`` outside a git checkout (provenance only, not part of run keys)."""
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=PACKAGE_ROOT, capture_output=True, text=True,
                                timeout=10)
        if commit.returncode != 0:
            return None
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=PACKAGE_ROOT,
                               capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return commit.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def available_cores() -> int:
    """The cores this process may use (its CPU affinity where the platform has one): the default ``--jobs``."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo`` on Linux, ``platform.processor()`` elsewhere)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def package_versions() -> dict[str, str]:
    """Installed version of each of ``PROVENANCE_PACKAGES`` (``not installed`` for a missing one)."""
    found = {}
    for package in PROVENANCE_PACKAGES:
        try:
            found[package] = version(package)
        except PackageNotFoundError:
            found[package] = "not installed"
    return found


def machine() -> dict[str, Any]:
    """The machine part of a matrix run's provenance record (columns of the ``matrix_runs`` table)."""
    return {
        "git_commit": git_commit(),
        "host": socket.gethostname(),
        "cpu_model": cpu_model(),
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "package_versions": json.dumps(package_versions(), sort_keys=True),
    }
