"""An installed entry-point plug-in of a new family: it is loaded, checked by ``selftest``, enters the code
version, and the project's own tests still pass with it installed.

The plug-in is installed the way pip would leave it, without pip: a module and a ``*.dist-info`` folder with
an ``entry_points.txt`` in a temporary directory put on ``PYTHONPATH`` of a subprocess (``importlib.metadata``
finds distributions on ``sys.path``). It is an explicit midpoint rule (Runge 1895; Hairer, Nørsett & Wanner,
Solving ODEs I, §II.1): order 2, 2 stages, unstable on the undamped oscillator at every step
(|R(ikh)|² = 1 + (kh)⁴/4 > 1), of a family no built-in matrix lists.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

PLUGIN_SOURCE = '''
"""A toy plug-in for the tests: the explicit midpoint rule."""

from typing import Callable, ClassVar

from foucault_bench.integrators import FixedStepIntegrator, register
from foucault_bench.models.jit import jit


@register
class ToyMidpoint(FixedStepIntegrator):
    name: ClassVar[str] = "toy_midpoint"
    family: ClassVar[str] = "toy-family"
    order: ClassVar[int] = 2
    stages: ClassVar[int] = 2
    reference: ClassVar[str] = "Hairer, Nørsett & Wanner, Solving ODEs I, §II.1"

    def make_step(self, model) -> Callable:
        acceleration = model.numba_acceleration

        @jit
        def step(x, y, vx, vy, h, p):
            ax, ay = acceleration(x, y, vx, vy, p)
            xm, ym, vxm, vym = x + 0.5 * h * vx, y + 0.5 * h * vy, vx + 0.5 * h * ax, vy + 0.5 * h * ay
            axm, aym = acceleration(xm, ym, vxm, vym, p)
            return x + h * vxm, y + h * vym, vx + h * axm, vy + h * aym

        return step
'''


ODD_PLUGIN_SOURCE = '''
"""A second toy plug-in of the same new family, each of whose integrators breaks a fact that the project's tests
check on the built-ins (``selftest`` is what judges a plug-in): a false stability limit, symplecticity and
rotation law; a tableau beside the shipped ones; no declared cost basis."""

from typing import ClassVar

import numpy as np

from foucault_bench.integrators import Integrator, Solution, register
from foucault_bench.integrators.methods.dopri5 import Dopri5
from toy_plugin import ToyMidpoint


@register
class ToyOverclaimed(ToyMidpoint):
    name: ClassVar[str] = "toy_overclaimed"
    stability_limit_kh: ClassVar[float] = 1.5
    symplectic: ClassVar[bool] = True

    def rotation_growth_per_step(self, kh, rate_ratio):
        return 1.0 + kh


@register
class ToyDopri(Dopri5):
    name: ClassVar[str] = "toy_dopri"
    family: ClassVar[str] = "toy-family"


@register
class ToyStill(Integrator):
    """Stays at the release point; ``cost_basis`` left at its default, None."""

    name: ClassVar[str] = "toy_still"
    family: ClassVar[str] = "toy-family"
    order: ClassVar[int | None] = None
    adaptive: ClassVar[bool] = True
    reference: ClassVar[str] = "none"

    def _solve(self, problem, *, step_s, tol, monitor):
        return Solution(t=problem.t_out, y=np.tile(problem.initial_state, (len(problem.t_out), 1)))
'''


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """A directory holding the plug-in module and its distribution metadata, as an installer leaves them."""
    site = tmp_path_factory.mktemp("site")
    (site / "toy_plugin.py").write_text(PLUGIN_SOURCE, encoding="utf-8")
    (site / "toy_oddities.py").write_text(ODD_PLUGIN_SOURCE, encoding="utf-8")
    dist_info = site / "toy_plugin-0.1.dist-info"
    dist_info.mkdir()
    (dist_info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-plugin\nVersion: 0.1\n", encoding="utf-8")
    (dist_info / "entry_points.txt").write_text("[foucault_bench.integrators]\ntoy_midpoint = toy_plugin\n"
                                                "toy_oddities = toy_oddities\n",
                                                encoding="utf-8")
    return site


def run(site: Path | None, *argv: str, timeout: float = 600) -> subprocess.CompletedProcess:
    environment = dict(os.environ)
    paths = [str(site)] if site else []
    environment["PYTHONPATH"] = os.pathsep.join(paths + [environment.get("PYTHONPATH", "")]).strip(os.pathsep)
    return subprocess.run([sys.executable, *argv], cwd=ROOT, env=environment, capture_output=True, text=True,
                          timeout=timeout)


PROBE = textwrap.dedent("""
    import json
    from foucault_bench.integrators import REGISTRY, is_built_in
    from foucault_bench.integrators.registry import ENTRY_POINT_MODULES
    from foucault_bench.bench.provenance import code_version
    toy = REGISTRY.get("toy_midpoint")
    print(json.dumps({"loaded": toy is not None and not is_built_in(toy), "family": toy and toy.family,
                      "modules": ENTRY_POINT_MODULES, "code_version": code_version()}))
""")


def test_entry_point_plug_in_is_loaded_and_enters_the_code_version(site: Path) -> None:
    """Other plug-ins installed beside it (entry points of the environment) change nothing here."""
    results = {}
    for label, directory in (("without", None), ("with", site)):
        result = run(directory, "-c", PROBE)
        assert result.returncode == 0, result.stderr
        results[label] = json.loads(result.stdout)
    assert results["with"]["loaded"] and results["with"]["family"] == "toy-family", results["with"]
    assert "toy_plugin" in results["with"]["modules"] and "toy_plugin" not in results["without"]["modules"]
    assert not results["without"]["loaded"]
    plugin = site / "toy_plugin.py"
    original = plugin.read_text(encoding="utf-8")
    plugin.write_text(original + "\n# edited\n", encoding="utf-8")
    try:
        edited = run(site, "-c", PROBE)
    finally:
        plugin.write_text(original, encoding="utf-8")
    versions = {results["with"]["code_version"], json.loads(edited.stdout)["code_version"],
                results["without"]["code_version"]}
    assert len(versions) == 3  # --resume cannot reuse rows


def test_selftest_checks_the_installed_plug_in(site: Path) -> None:
    result = run(site, "-m", "foucault_bench.bench.cli", "selftest", "toy_midpoint")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "ok    order on spherical: observed" in result.stdout
    assert "skip  stability limit" in result.stdout


PROJECT_TESTS = ("tests/test_matrix.py",
                 "tests/test_adaptive.py::test_declares_its_facts",
                 "tests/test_adaptive.py::test_the_library_drivers_are_discovered", "tests/test_structure.py",
                 "tests/test_timing.py::test_every_built_in_integrator_says_how_its_cost_arises",
                 "tests/test_tableau.py::test_the_shipped_tableaux_are_the_expected_ones",
                 "tests/test_studies.py::test_stable_below_the_limit_and_blown_up_above_it",
                 "tests/test_studies.py::test_measured_limits_match_the_declared_ones_without_rotation",
                 "tests/test_studies.py::test_rotation_growth_is_measured_beside_its_law")
"""The project's tests that enumerate the registry or assert what the built-in matrices cover (tests/test_selftest.py
and tests/test_fixed_step.py enumerate it only in their parametrization, whose ids the collection check compares,
so they are not run again here)."""


def collected_tests(site: Path | None) -> list[str]:
    """The ids of ``PROJECT_TESTS`` as pytest collects them, with the plug-ins of ``site`` installed or none."""
    result = run(site, "-m", "pytest", "-q", "--collect-only", "-p", "no:cacheprovider", *PROJECT_TESTS)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    return [line for line in result.stdout.splitlines() if "::" in line]


def test_the_project_suite_still_passes_with_the_plug_in_installed(site: Path) -> None:
    """The tests that enumerate the registry or assert what the built-in matrices cover judge the built-ins only,
    whatever plug-ins (here, ones that break what those tests check) are installed: with them, pytest collects
    the same tests (an enumeration by parametrization picks the built-ins only), and those tests pass. A test
    given one built-in integrator by its parameters (its body reads that one, by name) is judged by the
    collection alone here: the suite itself runs it."""
    from foucault_bench.integrators import built_in_names

    probe = run(site, "-c", "from foucault_bench.integrators import REGISTRY; print(*REGISTRY)")
    assert {"toy_midpoint", "toy_overclaimed", "toy_dopri", "toy_still"} <= set(probe.stdout.split()), probe.stderr
    tests = collected_tests(site)
    assert tests == collected_tests(None)
    built_in = set(built_in_names())
    per_integrator = [test for test in tests if "[" in test and built_in & set(test.split("[", 1)[1][:-1].split("-"))]
    assert per_integrator, "the per-integrator tests are told apart by their ids"
    result = run(site, "-m", "pytest", "-q", "-p", "no:cacheprovider", *PROJECT_TESTS,
                 *(f"--deselect={test}" for test in per_integrator), timeout=1800)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert f"{len(per_integrator)} deselected" in result.stdout, result.stdout[-3000:]


def test_selftest_judges_a_plug_in_that_overclaims(site: Path) -> None:
    result = run(site, "-m", "foucault_bench.bench.cli", "selftest", "toy_overclaimed")
    assert result.returncode != 0 and "FAIL" in result.stdout, result.stdout + result.stderr


def test_a_broken_entry_point_plug_in_is_reported_not_fatal(tmp_path: Path) -> None:
    dist_info = tmp_path / "broken_plugin-0.1.dist-info"
    dist_info.mkdir()
    (dist_info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugin\nVersion: 0.1\n", encoding="utf-8")
    (dist_info / "entry_points.txt").write_text("[foucault_bench.integrators]\nbroken = no_such_plugin_module\n",
                                                encoding="utf-8")
    probe = ("from foucault_bench.integrators import REGISTRY\n"
             "from foucault_bench.integrators.registry import ENTRY_POINT_ERRORS\n"
             "print('rk4' in REGISTRY, sorted(ENTRY_POINT_ERRORS))")
    result = run(tmp_path, "-c", probe)
    assert result.returncode == 0 and result.stdout.split() == ["True", "['broken']"], result.stdout + result.stderr
    assert "integrator plug-in 'broken'" in result.stderr and "No module named 'no_such_plugin_module'" in result.stderr
