"""Who leads when the forces are not conservative (bench/verdicts/nonconservative.py, the report's section in
reports/halls.py, the ``advise`` note): recomputed with SQL from the rows of a synthetic database written through
the real results store, independently of the code that builds the tables."""

from __future__ import annotations

import math
import sqlite3
import statistics

import pytest

MATRIX = {
    "name": "tiny_nonconservative", "scenes": ["guelph"], "integrators": ["rk4", "verlet", "gauss_legendre4", "dop853"],
    "kh": [0.2, 0.05], "tol": [1e-6, 1e-9],
    "scene": {"guelph_damped": {"base": "guelph", "model": "damped_linear", "drag_linear_per_s": 1e-3,
                                "title": "Guelph with drag", "why_model": "test", "assumptions": "test"}},
}
"""Two scenes of one hall: the ideal (conservative) one and a damped one (its model conserves no energy)."""

SYMPLECTIC = {"verlet", "gauss_legendre4"}
"""The symplectic integrators of ``MATRIX`` (Störmer-Verlet and the Gauss-Legendre collocation method: Hairer,
Lubich & Wanner, Geometric Numerical Integration, Thms. VI.3.4 and VI.4.3); rk4 and dop853 are not."""

# (scene, integrator, setting) → (reference error, CPU time s, energy error or energy-balance residual); None: diverged
SYNTHETIC = {
    ("guelph", "verlet", 0.2): (1e-7, 1.0, 2e-9), ("guelph", "verlet", 0.05): (1e-10, 4.0, 1e-10),
    ("guelph", "rk4", 0.2): (5e-7, 2.0, 1e-7), ("guelph", "rk4", 0.05): (2e-9, 8.0, 1e-9),
    ("guelph", "gauss_legendre4", 0.2): (2e-6, 10.0, 1e-8), ("guelph", "gauss_legendre4", 0.05): (1e-9, 40.0, 4e-11),
    ("guelph", "dop853", 1e-6): (3e-7, 3.0, 1e-8), ("guelph", "dop853", 1e-9): (5e-10, 6.0, 1e-11),
    ("guelph_damped", "verlet", 0.2): None, ("guelph_damped", "verlet", 0.05): (5e-8, 4.0, 2e-7),
    ("guelph_damped", "rk4", 0.2): (5e-7, 2.0, 3e-7), ("guelph_damped", "rk4", 0.05): (2e-9, 8.0, 1e-9),
    ("guelph_damped", "gauss_legendre4", 0.2): (2e-6, 10.0, 3e-6),
    ("guelph_damped", "gauss_legendre4", 0.05): (1e-9, 40.0, 1e-8),
    ("guelph_damped", "dop853", 1e-6): (2e-7, 1.5, 1e-7), ("guelph_damped", "dop853", 1e-9): (4e-10, 5.0, 1e-10),
}
"""Chosen so that a symplectic method leads on the ideal scene at both targets and not on the damped one (where
one target is met by a symplectic method 40/5 = 8 times dearer than the leader and the other by verlet at
4/1.5); the diverged verlet run is the cheapest of all and must be skipped."""


@pytest.fixture(scope="module")
def database(tmp_path_factory):
    from foucault_bench.bench.run.matrix import parse_matrix
    from foucault_bench.bench.run.execute import base_row
    from foucault_bench.bench.run.store import ResultsStore

    matrix = parse_matrix(MATRIX, source="tiny_nonconservative", default_name="tiny_nonconservative")
    path = tmp_path_factory.mktemp("nonconservative") / "runs.sqlite"
    with ResultsStore(path) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        for spec in matrix.runs:
            outcome = SYNTHETIC[(spec.scene.name, spec.integrator, spec.tol if spec.kh is None else spec.kh)]
            conserved = int(spec.scene.model_object.conserves_energy)
            row = {**base_row(spec, matrix_id), "status": "ok", "energy_conserved": conserved}
            if spec.kh is not None:  # the effective kh, as the runner stores it: a whole number of steps per output
                row["kh"] = spec.kh * (1.0 - 1e-3 * (1 + conserved))  # interval, different in each scene
            if outcome is None:
                row.update(status="diverged", message="diverged", reference_error=0.0, cpu_time_s=0.1)
            else:
                error, cost, energy = outcome
                row.update(reference_error=error, cpu_time_s=cost, wall_time_s=cost)
                row["energy_max_rel_error" if conserved else "energy_balance_max_rel_error"] = energy
            store.write_run(row)
        store.finish_matrix_run(matrix_id)
    return path


def frame(database):
    from foucault_bench.bench.run.store import ResultsStore

    with ResultsStore(database) as store:
        return store.frame()


def cheapest(connection, scene: str, target: float, names: set[str] | None = None) -> tuple[str, float] | None:
    """The SQL oracle: the cheapest ok run of the scene within the target (of ``names`` only, if given)."""
    rows = connection.execute(
        "SELECT integrator, cpu_time_s FROM runs WHERE scene = ? AND status = 'ok' AND abs(reference_error) <= ? "
        "ORDER BY cpu_time_s, abs(reference_error)", (scene, target)).fetchall()
    rows = [row for row in rows if names is None or row[0] in names]
    return rows[0] if rows else None


def test_the_leaders_and_the_symplectic_loss_are_recomputed_from_the_rows(database) -> None:
    from foucault_bench.bench.verdicts import nonconservative

    table = nonconservative.leaders(frame(database))
    loss = nonconservative.symplectic_loss(table).set_index("target")
    ratios: dict[tuple[bool, float], list[float]] = {}
    with sqlite3.connect(database) as connection:
        for scene, conservative in (("guelph", True), ("guelph_damped", False)):
            for target in (1e-6, 1e-9):
                leader = cheapest(connection, scene, target)
                symplectic = cheapest(connection, scene, target, SYMPLECTIC)
                row = table[(table["scene"] == scene) & (table["target"] == target)].iloc[0]
                assert bool(row["conservative"]) is conservative
                assert (row["leader"], row["leader_cost_s"]) == leader
                assert (row["symplectic"], row["symplectic_cost_s"]) == symplectic
                assert row["symplectic_ratio"] == pytest.approx(symplectic[1] / leader[1], rel=1e-12)
                ratios.setdefault((conservative, target), []).append(symplectic[1] / leader[1])
    for target in (1e-6, 1e-9):
        conservative_ratio = statistics.median(ratios[(True, target)])
        nonconservative_ratio = statistics.median(ratios[(False, target)])
        assert loss.loc[target, "conservative_median_ratio"] == pytest.approx(conservative_ratio, rel=1e-12)
        assert loss.loc[target, "nonconservative_median_ratio"] == pytest.approx(nonconservative_ratio, rel=1e-12)
        assert loss.loc[target, "loss"] == pytest.approx(nonconservative_ratio / conservative_ratio, rel=1e-12)
    # the synthetic rows make the point the section states: a symplectic method leads only where the model conserves
    assert set(table.loc[table["conservative"], "leader"]) <= SYMPLECTIC
    assert not set(table.loc[~table["conservative"].astype(bool), "leader"]) & SYMPLECTIC
    assert (loss["loss"] > 1.0).all()


def test_gauss_legendre_conservation_is_recomputed_from_the_rows(database) -> None:
    from foucault_bench.bench.verdicts import nonconservative

    table = nonconservative.conservation(frame(database)).set_index("kh")
    assert list(table.index) == [0.2, 0.05]  # the scenes' effective steps, grouped by the matrix's
    with sqlite3.connect(database) as connection:
        for kh in (0.2, 0.05):
            def median(column: str, conserved: int, kh: float = kh) -> float:
                values = [value for value, in connection.execute(
                    f"SELECT abs({column}) FROM runs WHERE integrator = 'gauss_legendre4' AND status = 'ok' "
                    "AND abs(kh / ? - 1) < 0.01 AND energy_conserved = ?", (kh, conserved)) if value is not None]
                return statistics.median(values) if values else math.nan
            assert table.loc[kh, "energy_error_conservative"] == median("energy_max_rel_error", 1)
            assert table.loc[kh, "energy_balance_nonconservative"] == median("energy_balance_max_rel_error", 0)


class Recorder:
    """A report builder that keeps what the section adds."""

    def __init__(self) -> None:
        self.tables: dict[str, object] = {}
        self.paragraphs: list[str] = []

    def add(self, *blocks) -> None:
        self.paragraphs += [block.text for block in blocks if hasattr(block, "text")]

    def table(self, table, name: str, title: str, notes=None, collapsible: bool = False) -> None:
        self.tables[name] = table


def test_the_report_section_draws_the_tables_and_states_the_numbers(database) -> None:
    from foucault_bench.reports import halls

    builder = Recorder()
    halls.add_section(builder, frame(database))
    assert set(builder.tables) == {"nonconservative_leaders", "symplectic_loss", "gauss_legendre_conservation"}
    sentence = builder.paragraphs[-1]
    with sqlite3.connect(database) as connection:
        for target in (1e-6, 1e-9):
            leader, leader_cost = cheapest(connection, "guelph_damped", target)
            _, symplectic_cost = cheapest(connection, "guelph_damped", target, SYMPLECTIC)
            assert f"at reference error ≤ {target:g} the non-conservative scenes are led by {leader};" in sentence
            assert (f"the cheapest symplectic run costs {symplectic_cost / leader_cost:.3g}× the leader's on the "
                    "non-conservative scenes (median over 1)") in sentence


def test_advise_notes_the_leader_on_a_nonconservative_scene_only(database) -> None:
    from foucault_bench.bench.verdicts.nonconservative import advise_note

    runs = frame(database)
    note = advise_note(runs[runs["scene"] == "guelph_damped"], 1e-6, "reference_error")
    with sqlite3.connect(database) as connection:
        leader, leader_cost = cheapest(connection, "guelph_damped", 1e-6)
        symplectic, symplectic_cost = cheapest(connection, "guelph_damped", 1e-6, SYMPLECTIC)
    assert note is not None and f"{leader} tol=1e-06 leads" in note
    assert f"{symplectic} kh=0.04995, costs {symplectic_cost / leader_cost:.3g}× as much" in note
    assert advise_note(runs[runs["scene"] == "guelph"], 1e-6, "reference_error") is None
    assert advise_note(runs[runs["scene"] == "guelph_damped"], 1e-12, "reference_error") is None


def test_the_advise_answer_carries_the_note_on_the_damped_scene_only(database) -> None:
    """Through ``advise`` itself (no search): the damped scene's answer has the note, the ideal one's has none."""
    from foucault_bench.bench.advise import advise
    from foucault_bench.bench.advise.target import Target
    from foucault_bench.bench.run.matrix import parse_matrix
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.verdicts.nonconservative import advise_note

    scenes = {spec.scene.name: spec.scene for spec in
              parse_matrix(MATRIX, source="tiny_nonconservative", default_name="tiny_nonconservative").runs}
    target = Target("reference_error", 1e-6)
    runs = frame(database)
    with ResultsStore(database) as store:
        damped = advise(store, scenes["guelph_damped"], target, search_jobs=None)
        ideal = advise(store, scenes["guelph"], target, search_jobs=None)
    assert advise_note(runs[runs["scene"] == "guelph_damped"], 1e-6, "reference_error") in damped.notes
    assert not [note for note in ideal.notes if "symplectic" in note]
