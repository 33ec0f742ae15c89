"""Fixtures shared by several test modules."""

from __future__ import annotations

import pytest

from foucault_bench.bench.problems.reference import CACHE_ENVIRONMENT_VARIABLE
from report_fixture import REPORT_GROUP
from report_fixture import fixture_database, fixture_report  # noqa: F401 - the report fixtures, for every module


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Every test that uses the fixture report goes to one pytest-xdist worker (group ``REPORT_GROUP``, with
    ``--dist loadgroup`` in the pytest options): that worker builds the report while the others run the rest."""
    for item in items:
        if "fixture_report" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group(REPORT_GROUP))


@pytest.fixture(scope="module")
def fresh_reference_cache(tmp_path_factory):
    """References of the using module go to a fresh cache directory (computed there, not read from a user's)."""
    patch = pytest.MonkeyPatch()
    patch.setenv(CACHE_ENVIRONMENT_VARIABLE, str(tmp_path_factory.mktemp("reference-cache")))
    yield
    patch.undo()
