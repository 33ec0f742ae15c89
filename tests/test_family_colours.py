"""Colour by family (reports.chart_style.family_colour): derived from the registry, so that no two registered
families share a colour, plug-in families included, and none takes a colour reserved for curves that are no
integrator's."""

from __future__ import annotations

import pytest
from matplotlib import colors

from foucault_bench.integrators import REGISTRY, register
from foucault_bench.integrators.registry import unregister
from foucault_bench.reports import chart_style, seed

RESERVED = (seed.GREY, seed.DAY_LENGTH_COLOUR)


def registered_families() -> list[str]:
    return sorted({integrator.family for integrator in REGISTRY.values()})


def assert_distinct_colours(families: list[str]) -> None:
    colours = {family: chart_style.family_colour(family) for family in families}
    assert len(set(colours.values())) == len(families), colours
    assert not set(colours.values()) & set(RESERVED), colours
    for colour in colours.values():
        assert colors.is_color_like(colour)


def test_every_registered_family_has_its_own_colour() -> None:
    assert len(registered_families()) >= 2
    assert_distinct_colours(registered_families())


@pytest.fixture
def plugin_families():
    """A family per plug-in, as many as it takes to go past the palette: subclasses of a built-in integrator
    registered under new names (``integrators.register``), unregistered afterwards."""
    template = type(REGISTRY["rk4"])
    needed = len(chart_style.FAMILY_PALETTE) + 3 - len(registered_families())
    names = [f"colour_test_{index}" for index in range(max(needed, 1))]
    for index, name in enumerate(names):
        register(type(f"ColourTest{index}", (template,), {"name": name, "family": f"plugin-family-{index}",
                                                          "__module__": __name__}))
    try:
        yield [REGISTRY[name].family for name in names]
    finally:
        for name in names:
            unregister(name)


def test_plugin_families_get_colours_of_their_own_past_the_palette(plugin_families) -> None:
    families = registered_families()
    assert set(plugin_families) <= set(families) and len(families) > len(chart_style.FAMILY_PALETTE)
    assert_distinct_colours(families)


def test_a_family_no_longer_registered_shares_no_registered_family_colour() -> None:
    registered = {chart_style.family_colour(family) for family in registered_families()}
    assert chart_style.family_colour("a-removed-plugin-family") not in registered
