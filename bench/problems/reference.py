"""Reference solutions: each scene integrated once in quadruple precision and kept in a disk cache.

The reference is heyoka's Taylor integrator in IEEE binary128 (``heyoka_taylor_quad`` at
``integrators.methods.heyoka_taylor.REFERENCE_TOLERANCE`` = 1e-33; integrators/README.md "Adaptive methods": an
independent reference far below any double-precision error), run on the scene's own output grid, so every
integrator of the scene is compared with it point for point. Its state is rounded to float64 once, at the output.

**Cache.** One ``.npz`` file per reference under ``$FOUCAULT_BENCH_CACHE/references`` (default
``~/.cache/foucault-bench/references``), named by a SHA-256 of the scene's physics (model, parameters, duration,
output interval; not its name or texts), the reference integrator and tolerance, and a code version: a hash
of the sources that determine the trajectory (``models/*.py``, the reference integrator's module,
``integrators/adaptive.py`` with the tolerance mapping) and heyoka's version. Only the trajectory is stored;
turning points and the precession rate are derived on loading (``bench.verdicts``), so a change in the
measurement never serves stale numbers. Writes are atomic (a temporary file in the same directory, then
``os.replace``) and a per-reference lock file (``fcntl.flock``) makes concurrent processes compute a missing
reference once: the others wait and load it. Within a process, loaded references are kept in memory.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import inspect
import json
import os
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path
from typing import Any, Sequence, cast

import numpy as np

from foucault_bench.bench.problems.scene_key import physics_identity
from foucault_bench.bench.problems.scenes import Scene
from foucault_bench.bench.provenance import PACKAGE_ROOT, source_digest
from foucault_bench.integrators import STATUS_OK, get_integrator
from foucault_bench.integrators.methods.heyoka_taylor import REFERENCE_TOLERANCE

REFERENCE_INTEGRATOR = "heyoka_taylor_quad"
CACHE_ENVIRONMENT_VARIABLE = "FOUCAULT_BENCH_CACHE"
DEFAULT_CACHE_DIRECTORY = Path.home() / ".cache" / "foucault-bench"
CACHE_FORMAT = 1
"""Bump when the layout of the cached files changes."""


@dataclass
class Reference:
    """A scene's reference solution on its output grid.

    Attributes:
        t: output times (s), the scene's grid.
        y: states (x, y, ẋ, ẏ) in m and m/s, shape (len(t), 4), float64.
        turning_points: (t in s, x in m, y in m) of each radius maximum, release point included for a release
            from rest (``bench.problems.turning_points.turning_points_from_grid``), shape (n, 3).
        precession_rate_rad_s: swing-plane rate measured from them (counter-clockwise about up positive).
        precession_rate_stderr_rad_s: its standard error.
        key: the cache key (see module docstring).
        integrator: name of the integrator that computed it.
        tolerance: its ``tol``.
        steps: its step count.
        compute_time_s: wall time the computation took (when it was computed, not loaded).
    """

    t: np.ndarray
    y: np.ndarray
    turning_points: np.ndarray
    precession_rate_rad_s: float
    precession_rate_stderr_rad_s: float = float("nan")
    key: str = ""
    integrator: str = REFERENCE_INTEGRATOR
    tolerance: float = REFERENCE_TOLERANCE
    steps: int | None = None
    compute_time_s: float = float("nan")


def cache_directory() -> Path:
    """Where references are cached: ``$FOUCAULT_BENCH_CACHE/references`` or ``~/.cache/foucault-bench/references``."""
    root = os.environ.get(CACHE_ENVIRONMENT_VARIABLE)
    return (Path(root).expanduser() if root else DEFAULT_CACHE_DIRECTORY) / "references"


@functools.lru_cache(maxsize=None)
def sources_version() -> str:
    """SHA-256 (16 hex digits) of the sources that determine a reference trajectory, and heyoka's version
    (``bench.provenance.source_digest``; the version from the package metadata: importing heyoka to read
    it would cost a worker about 0.7 s)."""
    integrator_module = Path(cast(str, inspect.getsourcefile(type(get_integrator(REFERENCE_INTEGRATOR))))).resolve()
    sources = sorted((PACKAGE_ROOT / "models").glob("*.py"))
    sources += [integrator_module, PACKAGE_ROOT / "integrators" / "adaptive.py"]
    return source_digest(f"heyoka {version('heyoka')}; format {CACHE_FORMAT}", dict.fromkeys(sources))


def reference_key(scene: Scene) -> str:
    """Cache key of the scene's reference: SHA-256 (24 hex digits) of its physics, the reference integrator
    and tolerance, and ``sources_version``."""
    identity = {
        "scene": physics_identity(scene),
        "integrator": REFERENCE_INTEGRATOR,
        "tolerance": REFERENCE_TOLERANCE,
        "code": sources_version(),
    }
    return hashlib.sha256(json.dumps(identity, sort_keys=True, default=repr).encode()).hexdigest()[:24]


_loaded: dict[tuple[str, str], Reference] = {}


def reference_for(scene: Scene) -> Reference:
    """The scene's reference: from this process's memory, else the disk cache, else computed (then cached).

    Raises ``RuntimeError`` when the reference integrator does not finish the scene (nothing is cached then).
    """
    directory = cache_directory()
    key = reference_key(scene)
    memory_key = (str(directory), key)
    if memory_key in _loaded:
        return _loaded[memory_key]
    directory.mkdir(parents=True, exist_ok=True)
    with open(directory / f"{key}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
        reference = load_cached(scene)
        if reference is None:
            reference = _compute(scene, key)
            _store(directory / f"{key}.npz", scene, reference)
    _loaded[memory_key] = reference
    return reference


def references_for(scenes: Sequence[Scene], workers: int | None = None) -> list[Reference]:
    """The references of many scenes (an ensemble's members), in their order, each as ``reference_for`` gives it.

    heyoka has no batch mode in real128 (``integrators.batch_heyoka``), so the missing references are computed
    concurrently instead, one ``reference_for`` per thread on ``workers`` threads (default: the machine's
    cores): heyoka releases the interpreter lock while it propagates, and each thread integrates with its own
    copy of the compiled integrator (``integrators.methods.heyoka_taylor.working_integrator``). Every reference
    is the one ``reference_for`` computes alone, bit for bit, cached the same way. The threads only fill the
    disk cache; the turning points and rate are then measured here, in the calling thread, from the cached
    trajectories (measured in a worker thread, a rate could differ from the one-by-one value in its last bits).
    """
    unique = {reference_key(scene): scene for scene in scenes}
    directory = str(cache_directory())
    missing = [scene for key, scene in unique.items() if (directory, key) not in _loaded]
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        list(pool.map(reference_for, missing))
    for key in {reference_key(scene) for scene in missing}:
        _loaded.pop((directory, key), None)
    by_key = {key: reference_for(scene) for key, scene in unique.items()}
    return [by_key[reference_key(scene)] for scene in scenes]


def load_cached(scene: Scene) -> Reference | None:
    """The scene's reference from the disk cache, or ``None`` if it is not there (never computes)."""
    key = reference_key(scene)
    path = cache_directory() / f"{key}.npz"
    if not path.exists():
        return None
    with np.load(path, allow_pickle=False) as data:
        t, y = data["t"], data["y"]
        metadata = json.loads(str(data["metadata"]))
    return _derive(scene, t, y, key=key, steps=metadata["steps"], compute_time_s=metadata["compute_time_s"])


def _compute(scene: Scene, key: str) -> Reference:
    problem = scene.problem()
    started = time.perf_counter()
    solution = get_integrator(REFERENCE_INTEGRATOR).solve(problem, tol=REFERENCE_TOLERANCE, monitor=False)
    elapsed = time.perf_counter() - started
    if solution.status != STATUS_OK:
        raise RuntimeError(f"the reference ({REFERENCE_INTEGRATOR}, tol {REFERENCE_TOLERANCE:g}) of scene "
                           f"{scene.name} did not finish: {solution.status}: {solution.message}")
    return _derive(scene, problem.t_out, np.asarray(solution.y, dtype=np.float64), key=key, steps=solution.steps,
                   compute_time_s=elapsed)


def _derive(scene: Scene, t: np.ndarray, y: np.ndarray, **provenance: Any) -> Reference:
    """A ``Reference`` with the turning points and precession rate measured on its grid."""
    # here, not at the top: the turning points import scipy, which a process that only reads matrices (and so
    # this module's constants) should not pay. No cycle: bench.problems.turning_points imports only models.
    from foucault_bench.bench.problems.turning_points import (
        grid_accelerations, precession_rate, released_from_rest, turning_points_from_grid,
    )

    points = turning_points_from_grid(t, y, grid_accelerations(scene.model_object, scene.params, y),
                                      released_from_rest(scene.params))
    rate, stderr = precession_rate(points)
    return Reference(t=t, y=y, turning_points=points, precession_rate_rad_s=rate,
                     precession_rate_stderr_rad_s=stderr, **provenance)


def _store(path: Path, scene: Scene, reference: Reference) -> None:
    """Write atomically: a temporary file in the same directory, flushed to disk, renamed over ``path``."""
    metadata = {
        "key": reference.key,
        "scene": scene.name,
        "physics": physics_identity(scene),
        "integrator": reference.integrator,
        "tolerance": reference.tolerance,
        "code_version": sources_version(),
        "steps": reference.steps,
        "compute_time_s": reference.compute_time_s,
    }
    handle = tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.stem}.", suffix=".tmp", delete=False)
    try:
        with handle:
            np.savez(handle, t=reference.t, y=reference.y, metadata=np.array(json.dumps(metadata, default=repr)))
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(handle.name, path)
    except BaseException:
        Path(handle.name).unlink(missing_ok=True)
        raise
