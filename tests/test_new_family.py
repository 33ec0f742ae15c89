"""A new integrator family enters the studies and the colour table from the registry alone: a fake built-in
family (a subclass of a built-in integrator under a new name and family, registered from a module of the
built-in methods package and unregistered afterwards) is a family representative, runs in the long-time energy
study's default runs, and gets a colour no other family has."""

from __future__ import annotations

import numpy as np
import pytest

from foucault_bench.bench.studies import LongTimeEnergyConfig, family_representatives, long_time_energy
from foucault_bench.integrators import REGISTRY, register
from foucault_bench.integrators.registry import METHODS_PACKAGE, built_in_names, is_built_in, unregister
from foucault_bench.reports import chart_style as charts

FAKE_NAME = "fake_new_family_method"
FAKE_FAMILY = "fake-new-family"


@pytest.fixture
def fake_family():
    template = type(REGISTRY["heun3"])
    register(type("FakeNewFamily", (template,), {"name": FAKE_NAME, "family": FAKE_FAMILY,
                                                  "__module__": f"{METHODS_PACKAGE}.fake_new_family"}))
    try:
        yield FAKE_NAME
    finally:
        unregister(FAKE_NAME)


def test_a_new_family_is_a_representative_and_runs_in_the_energy_study(fake_family) -> None:
    assert is_built_in(fake_family) and fake_family in built_in_names()
    assert family_representatives()[FAKE_FAMILY] == fake_family
    config = LongTimeEnergyConfig(model="linear", length_m=10.0, amplitude_m=0.5, duration_s=60.0, n_out=31)
    default_runs = config.chosen_runs()
    assert (fake_family, config.kh) in default_runs
    only_fake = LongTimeEnergyConfig(**{**config.__dict__, "runs": ((fake_family, config.kh),)})
    table = long_time_energy(only_fake, progress=False)
    rows = table[table["integrator"] == fake_family]
    assert set(rows["family"]) == {FAKE_FAMILY} and set(rows["status"]) == {"ok"}
    assert np.all(np.isfinite(rows["energy_rel_error"]))


def test_a_new_family_gets_a_colour_of_its_own(fake_family) -> None:
    families = sorted({integrator.family for integrator in REGISTRY.values()})
    assert FAKE_FAMILY in families
    colours = {family: charts.family_colour(family) for family in families}
    others = {colour for family, colour in colours.items() if family != FAKE_FAMILY}
    assert colours[FAKE_FAMILY] not in others
    assert charts.integrator_style(fake_family, FAKE_FAMILY)["color"] == colours[FAKE_FAMILY]


def test_the_extrapolation_family_is_registered_with_its_own_colour() -> None:
    """The families this change adds take their colours from the same table, distinct from every other."""
    families = sorted({integrator.family for integrator in REGISTRY.values()})
    assert "extrapolation" in families
    assert family_representatives()["extrapolation"] == "gbs4"
    colours = [charts.family_colour(family) for family in families]
    assert len(set(colours)) == len(colours)
