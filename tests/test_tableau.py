"""Butcher tableaux: the rooted trees behind the order conditions, the shipped tableaux (the embedded pairs and the
fixed-step methods stepped from their tableau), and the rejection of a tableau with one wrong coefficient (every
coefficient of every shipped tableau, in turn)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from foucault_bench.integrators import REGISTRY, built_in_names
from foucault_bench.integrators.embedded_rk import EmbeddedRungeKutta
from foucault_bench.integrators.explicit_rk import ExplicitRungeKutta
from foucault_bench.integrators.tableau import (
    CONDITION_RTOL,
    MAX_CHECKED_ORDER,
    ButcherTableau,
    order_condition_residuals,
    rooted_trees,
    tree_density,
    tree_order,
)

TABLEAUX = {name: REGISTRY[name].tableau for name in built_in_names()  # a plug-in's tableau: its selftest
            if isinstance(REGISTRY[name], (EmbeddedRungeKutta, ExplicitRungeKutta))}
FIXED_STEP_TABLEAUX = sorted(name for name in TABLEAUX if isinstance(REGISTRY[name], ExplicitRungeKutta))
RELATIVE_PERTURBATION = 1.0e-6
"""A coefficient wrong in its seventh significant digit."""


def test_rooted_tree_counts_and_densities() -> None:
    """HNW I, Table II.2.1: 1, 1, 2, 4, 9, 20, 48, 115 trees; γ of the tall and the bushy tree of order 5."""
    assert [len(rooted_trees(n)) for n in range(1, 9)] == [1, 1, 2, 4, 9, 20, 48, 115]
    assert tree_density((((((),),),),)) == 120  # the chain of 5 nodes: 5!
    assert tree_density(((), (), (), ())) == 5  # the bush: ρ


def test_the_shipped_tableaux_are_the_expected_ones() -> None:
    assert set(TABLEAUX) == {"dopri5", "dop853", "tsit5", "vern7", "vern9", "explicit_euler", "heun3", "rk4"}
    facts = {name: (t.stages, t.order, t.error_order, t.error_estimator_order, t.extra_stages, t.dense_order)
             for name, t in TABLEAUX.items() if t.is_embedded}
    assert facts == {"dopri5": (6, 5, 4, 4, 0, 4), "tsit5": (6, 5, 4, 4, 0, 4), "dop853": (12, 8, 5, 7, 3, 7),
                     "vern7": (10, 7, 6, 6, 5, 6), "vern9": (16, 9, 8, 8, 9, 9)}
    plain = {name: (t.stages, t.order, t.error_order, t.dense_order, t.has_dense_output)
             for name, t in TABLEAUX.items() if not t.is_embedded}
    assert plain == {"explicit_euler": (1, 1, None, None, False), "heun3": (3, 3, None, None, False),
                     "rk4": (4, 4, None, None, False)}
    for name in FIXED_STEP_TABLEAUX:  # the declared facts are the tableau's
        assert (REGISTRY[name].order, REGISTRY[name].stages) == (TABLEAUX[name].order, TABLEAUX[name].stages)


@pytest.mark.parametrize("name", sorted(TABLEAUX))
def test_the_main_weights_have_exactly_the_declared_order(name: str) -> None:
    """The conditions hold up to the declared order and some condition of the next order fails (so the
    declared order is the true one, not a lower bound)."""
    tableau = TABLEAUX[name]
    a = tableau.extended_a()[: tableau.stages + 1, : tableau.stages + 1]
    b = np.concatenate([tableau.b, [0.0]])
    rows = order_condition_residuals(a, b, tableau.order + 1)
    assert all(abs(r) <= CONDITION_RTOL * s for tree, r, s in rows if tree_order(tree) <= tableau.order)
    assert any(abs(r) > 1e-6 for tree, r, s in rows if tree_order(tree) == tableau.order + 1)


def _coefficient_fields(tableau: ButcherTableau) -> list[tuple[str, tuple]]:
    """(field, index) of every non-zero coefficient."""
    places = []
    for field in ("c", "b", "error_weights", "secondary_error_weights", "dense_c"):
        values = getattr(tableau, field)
        if values is not None:
            places += [(field, (i,)) for i, v in enumerate(values) if v != 0.0]
    for field in ("a", "dense_a", "dense_weights", "dense_hairer"):
        places += [(field, (i, j)) for i, row in enumerate(getattr(tableau, field) or ()) for j, v in enumerate(row)
                   if v != 0.0]
    return places


def _perturbed(tableau: ButcherTableau, field: str, index: tuple) -> dict:
    values = np.array(getattr(tableau, field), dtype=np.float64)
    values[index] *= 1.0 + RELATIVE_PERTURBATION
    as_tuples = tuple(map(tuple, values)) if values.ndim == 2 else tuple(values)
    return {field: as_tuples}


@pytest.mark.parametrize("name", sorted(TABLEAUX))
def test_every_wrong_coefficient_is_rejected(name: str) -> None:
    tableau = TABLEAUX[name]
    places = _coefficient_fields(tableau)
    assert len(places) >= 2 * tableau.stages - 1  # at least one weight and one row entry per further stage
    for field, index in places:
        with pytest.raises(ValueError, match="invalid"):
            dataclasses.replace(tableau, **_perturbed(tableau, field, index))


@pytest.mark.parametrize("name", sorted(name for name, t in TABLEAUX.items() if np.count_nonzero(t.b) >= 2))
def test_a_wrong_weight_that_keeps_the_low_order_conditions_is_rejected(name: str) -> None:
    """Moving δ from one weight to another keeps Σbᵢ = 1 and the row sums: only a higher-order condition
    catches it."""
    tableau = TABLEAUX[name]
    b = np.array(tableau.b)
    i, j = np.flatnonzero(b)[:2]
    b[i] += RELATIVE_PERTURBATION
    b[j] -= RELATIVE_PERTURBATION
    with pytest.raises(ValueError, match="order condition"):
        dataclasses.replace(tableau, b=tuple(b), dense_weights=tableau.dense_weights)


def test_structural_mistakes_are_reported() -> None:
    tableau = TABLEAUX["dopri5"]
    implicit = [list(row) for row in tableau.a]
    implicit[2][2] = 0.1
    with pytest.raises(ValueError, match="lower triangular"):
        dataclasses.replace(tableau, a=tuple(map(tuple, implicit)))
    with pytest.raises(ValueError, match="b must hold 6"):
        dataclasses.replace(tableau, b=tableau.b[:5])
    with pytest.raises(ValueError, match="order must be"):
        dataclasses.replace(tableau, order=MAX_CHECKED_ORDER + 1)


@pytest.mark.parametrize(("name", "stable_up_to", "unstable_at"),
                         [("dopri5", 0.99, 1.0), ("tsit5", 0.47, 0.5), ("dop853", 5.95, 6.0), ("vern7", 0.08, 0.5),
                          ("vern9", 2.75, 2.8)])
def test_imaginary_axis_stability_stated_in_the_docstrings(name: str, stable_up_to: float, unstable_at: float) -> None:
    """|R(iy)| ≤ 1 on (0, stable_up_to] and > 1 at unstable_at, R(z) = 1 + z bᵀ(I − zA)⁻¹𝟙 (HW II, §IV.2)."""
    tableau = TABLEAUX[name]
    a, b, ones = np.asarray(tableau.a), np.asarray(tableau.b), np.ones(tableau.stages)

    def amplification(y: float) -> float:
        return abs(1.0 + 1j * y * b @ np.linalg.solve(np.eye(tableau.stages) - 1j * y * a, ones))

    assert max(amplification(y) for y in np.linspace(1e-3, stable_up_to, 2000)) <= 1.0 + 1e-13
    assert amplification(unstable_at) > 1.0 + 1e-9


@pytest.mark.parametrize("name", FIXED_STEP_TABLEAUX)
def test_the_declared_stability_limit_is_the_tableaus(name: str) -> None:
    """The imaginary-axis limit computed from the coefficients, R(z) = 1 + z bᵀ(I − zA)⁻¹𝟙 (HW II, §IV.2), is the
    declared ``stability_limit_kh`` (none: |R(iy)| > 1 for every y > 0)."""
    tableau, declared = TABLEAUX[name], REGISTRY[name].stability_limit_kh
    a, b, ones = np.asarray(tableau.a), np.asarray(tableau.b), np.ones(tableau.stages)

    def amplification(y: float) -> float:
        return abs(1.0 + 1j * y * b @ np.linalg.solve(np.eye(tableau.stages) - 1j * y * a, ones))

    if declared is None:
        assert all(amplification(y) > 1.0 for y in np.linspace(1e-3, 10.0, 2000))
        return
    assert max(amplification(y) for y in np.linspace(1e-3, declared * (1 - 1e-6), 2000)) <= 1.0 + 1e-13
    assert amplification(declared * (1 + 1e-4)) > 1.0 + 1e-12


def test_error_weights_and_dense_output_are_optional_but_complete() -> None:
    rk4 = TABLEAUX["rk4"]
    with pytest.raises(ValueError, match="error_weights and error_order together"):
        dataclasses.replace(rk4, error_order=3)
    with pytest.raises(ValueError, match="dense_weights or as dense_hairer, with dense_order"):
        dataclasses.replace(rk4, dense_order=3)
    with pytest.raises(ValueError, match="order condition"):  # a plain tableau's order is checked as a pair's
        dataclasses.replace(rk4, order=5)
    with pytest.raises(ValueError, match="order condition"):
        dataclasses.replace(TABLEAUX["heun3"], b=(0.25, 0.25, 0.5))  # Σb = 1 and row sums hold: order 1 only
    with pytest.raises(TypeError, match="needs a tableau with error weights"):
        type("PlainPair", (EmbeddedRungeKutta,), {"name": "plain_pair", "tableau": rk4, "reference": "test"})
