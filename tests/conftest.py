"""Fixtures shared by several test modules."""

from __future__ import annotations

import pytest

from foucault_bench.bench.problems.reference import CACHE_ENVIRONMENT_VARIABLE
from report_fixture import fixture_database, fixture_report  # noqa: F401 - the report fixtures, for every module


@pytest.fixture(scope="module")
def fresh_reference_cache(tmp_path_factory):
    """References of the using module go to a fresh cache directory (computed there, not read from a user's)."""
    patch = pytest.MonkeyPatch()
    patch.setenv(CACHE_ENVIRONMENT_VARIABLE, str(tmp_path_factory.mktemp("reference-cache")))
    yield
    patch.undo()
