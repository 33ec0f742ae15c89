"""The study computations of bench.studies, at small sizes, against what the physics and numerics say
(integrators/README.md "Fixed-step methods on this problem"; models/README.md "Airy precession"): explicit Euler's
energy grows as (1 + (kh)²)ⁿ, Verlet's stays within (kh)²/4, each fixed-step integrator is stable below its
declared limit and blows up above it, and the measured precession follows −Ω_E sin φ with the Airy correction at
every latitude."""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.studies import (
    STUDIES,
    LongTimeEnergyConfig,
    PrecessionLatitudeConfig,
    ReleaseAzimuthConfig,
    SeedConfig,
    StabilitySweepConfig,
    ensure_studies,
    family_representatives,
    long_time_energy,
    precession_vs_latitude,
    precession_vs_release_azimuth,
    stability_sweep,
)
from foucault_bench.bench.studies.long_time_roundoff import RoundoffConfig
from foucault_bench.integrators.fixed_step import uniform_output_stride
from foucault_bench.integrators.registry import REGISTRY, built_in_names
from foucault_bench.models import PendulumParameters
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S

LONG_TIME = LongTimeEnergyConfig(model="linear", length_m=10.0, amplitude_m=0.5, duration_s=600.0, n_out=301,
                                 runs=(("explicit_euler", 0.02), ("verlet", 0.2), ("heyoka_taylor", 1e-15),
                                       ("not_registered", 0.1)))


@pytest.fixture(scope="module")
def energy_table() -> pd.DataFrame:
    return long_time_energy(LONG_TIME, progress=False)


def _params(config) -> PendulumParameters:
    return PendulumParameters(length_m=config.length_m, latitude_deg=config.latitude_deg,
                              amplitude_m=config.amplitude_m)


def _effective_kh(config: LongTimeEnergyConfig, kh: float) -> tuple[float, float]:
    """(effective k·h, effective step in s) after the fixed-step loop shortens the step to fit the grid."""
    params = _params(config)
    k = params.pendulum_frequency_rad_s
    _, step = uniform_output_stride(np.linspace(0.0, config.duration_s, config.n_out), kh / k)
    return k * step, step


def test_explicit_euler_energy_grows_as_the_stability_function_says(energy_table: pd.DataFrame) -> None:
    euler = energy_table[energy_table["integrator"] == "explicit_euler"]
    assert set(euler["status"]) == {"ok"}
    kh, step = _effective_kh(LONG_TIME, 0.02)
    steps = euler["t_s"].to_numpy() / step
    theory = (1.0 + kh * kh) ** steps - 1.0  # |1 + ikh|² per step (Hairer, Nørsett & Wanner I, §IV.2)
    # The Coriolis term splits the two circular modes' growth factors into 1 + h²(Ω ∓ a)²: the energy ratio
    # can differ from (1 + (kh)²)ⁿ by exp(±2(a/k)·n(kh)²); allow twice that.
    a_over_k = _params(LONG_TIME).vertical_rate_rad_s / _params(LONG_TIME).pendulum_frequency_rad_s
    tolerance = 4.0 * a_over_k * steps * kh * kh + 1e-12
    measured = euler["energy_rel_error"].to_numpy()
    assert np.all(np.abs((1.0 + measured) / (1.0 + theory) - 1.0) <= tolerance)
    assert measured[-1] > 1.0  # it really grows: the energy has more than doubled in 600 s


def test_verlet_energy_stays_within_the_modified_energy_bound(energy_table: pd.DataFrame) -> None:
    verlet = energy_table[energy_table["integrator"] == "verlet"]
    kh, _ = _effective_kh(LONG_TIME, 0.2)
    # Störmer-Verlet conserves H̃ = ½v² + ½k²x²(1 − (kh)²/4) on the oscillator, so E/E₀ − 1 ∈ [−(kh)²/4, 0]
    # for a release from rest (Hairer, Lubich & Wanner, GNI §I.1 and §IX); 1e-9 allows round-off.
    errors = verlet["energy_rel_error"].to_numpy()
    assert np.all(errors <= 1e-9) and np.all(errors >= -(kh * kh / 4.0) - 1e-9)
    assert errors.min() < -0.5 * kh * kh / 4.0  # the oscillation is there (the bound is not vacuous)


def test_taylor_energy_stays_near_round_off(energy_table: pd.DataFrame) -> None:
    taylor = energy_table[energy_table["integrator"] == "heyoka_taylor"]
    assert set(taylor["status"]) == {"ok"}
    # tol 1e-15 per step, at most ~100 steps per swing, 600 s / 6.3 s swings: accumulated ≤ 1e-15·100·100
    assert taylor["energy_rel_error"].abs().max() < 1e-11


def test_an_unknown_integrator_becomes_a_failed_run_not_a_crash(energy_table: pd.DataFrame) -> None:
    missing = energy_table[energy_table["integrator"] == "not_registered"]
    assert len(missing) == LONG_TIME.n_out - 1
    assert set(missing["status"]) == {"failed"}
    assert "unknown integrator" in missing["message"].iloc[0]
    assert missing["energy_rel_error"].isna().all()


STABILITY = StabilitySweepConfig(steps=400, kh=(0.5, 1.9, 2.1, 2.7, 2.9, 3.5, 6.1))


@pytest.fixture(scope="module")
def stability_table() -> pd.DataFrame:
    return stability_sweep(STABILITY, progress=False)


def test_every_fixed_step_integrator_is_swept_with_and_without_rotation(stability_table: pd.DataFrame) -> None:
    fixed_step = {name for name, integrator in REGISTRY.items() if not integrator.adaptive}
    assert set(stability_table["integrator"]) == fixed_step
    for (name, rotation), rows in stability_table.groupby(["integrator", "rotation"]):
        declared = REGISTRY[name].stability_limit_kh
        limits = rows["stability_limit_kh"].to_numpy()
        assert (np.isnan(limits).all() if declared is None else np.all(limits == declared))
        assert sorted(rows["kh"]) == sorted(STABILITY.kh)
        assert (rows["rate_ratio"] > 0).all() == rotation


def test_stable_below_the_limit_and_blown_up_above_it(stability_table: pd.DataFrame) -> None:
    built_in = stability_table[stability_table["integrator"].isin(built_in_names())]  # plug-ins: their selftest
    for row in built_in.itertuples():
        limit = row.stability_limit_kh
        if math.isnan(limit):
            # explicit Euler: energy grows by (1 + (kh)²) every step, whatever the step
            if row.status != "diverged":
                assert row.energy_max_rel_error >= 0.99 * ((1 + row.kh**2) ** STABILITY.steps - 1), row
        elif row.kh <= 0.95 * limit:
            # stable: bounded. Symplectic Euler's energy ratio along a stable orbit reaches
            # (1 + kh/2)/(1 − kh/2) (its conserved quadratic form), 39 at kh = 1.9; 100 leaves margin (with
            # rotation its growth of ≤ 3.2e-4 per step adds at most a factor e^0.26 over 400 steps).
            assert row.status == "ok" and row.energy_max_rel_error < 100.0, row
        elif row.kh >= 1.02 * limit:
            # unstable: an eigenvalue of modulus > 1 (RK4 |R(2.9i)|² = 1.42) over 400 steps
            assert row.status == "diverged" or row.energy_max_rel_error > 1e6, row


def test_measured_limits_match_the_declared_ones_without_rotation(stability_table: pd.DataFrame) -> None:
    """Bisected on the one-step map's growth between the grid points around the declared limit (to 1e-4 in kh).
    Within 1e-3 relative: the implicit schemes' fixed-point sweeps stop reaching their hand-over to Newton within
    their sweep budget 1e-4 (relative) below their limit (``integrators.gauss``)."""
    built_in = stability_table["integrator"].isin(built_in_names())  # plug-ins: their selftest
    still = stability_table[built_in & ~stability_table["rotation"] & stability_table["stability_limit_kh"].notna()]
    for name, rows in still.groupby("integrator"):
        assert rows["measured_limit_kh"].iloc[0] == pytest.approx(rows["stability_limit_kh"].iloc[0], rel=1e-3), name


def test_rotation_growth_is_measured_beside_its_law(stability_table: pd.DataFrame) -> None:
    """Symplectic Euler with rotation: no bounded k·h (measured limit NaN), growth within 10 % of the law."""
    built_in = stability_table["integrator"].isin(built_in_names())  # plug-ins: their selftest
    lawful = stability_table[built_in & stability_table["rotation"] & stability_table["growth_theory"].notna()]
    assert set(lawful["integrator"]) == {name for name in built_in_names()
                                         if REGISTRY[name].rotation_growth_per_step(1.0, 1e-4) is not None}
    assert lawful["measured_limit_kh"].isna().all()
    ratio = (lawful["growth_per_step"] / lawful["growth_theory"]).to_numpy()
    assert np.all(np.abs(ratio - 1.0) < 0.1), ratio


def test_precession_follows_the_airy_corrected_textbook_rate() -> None:
    config = PrecessionLatitudeConfig(duration_s=900.0, n_latitudes=7, amplitude_m=1.0, length_m=10.0)
    table = precession_vs_latitude(config, progress=False)
    assert list(table["latitude_deg"]) == list(np.linspace(-90.0, 90.0, 7))
    theta0 = config.amplitude_m / config.length_m
    # Beyond Airy's (3/8)θ₀² the release side adds a term of order θ₀³ (models/README.md "Airy precession"):
    # allow θ₀³·Ω_E (four times ¼θ₀³) plus three standard errors.
    tolerance = theta0**3 * SIDEREAL_EARTH_RATE_RAD_S + 3.0 * table["rate_stderr_rad_s"]
    assert np.all(np.abs(table["rate_rad_s"] - table["airy_rate_rad_s"]) <= tolerance)
    textbook = -SIDEREAL_EARTH_RATE_RAD_S * np.sin(np.radians(table["latitude_deg"]))
    assert np.allclose(table["textbook_rate_rad_s"], textbook, rtol=1e-15, atol=0.0)
    north = table[table["latitude_deg"] > 0]
    south = table[table["latitude_deg"] < 0]
    assert (north["rate_rad_s"] < 0).all() and (south["rate_rad_s"] > 0).all()  # clockwise in the north
    period = 2 * math.pi / math.sqrt(9.81 / config.length_m)
    expected_points = 2 * config.duration_s / period
    assert np.all(np.abs(table["turning_points"] - expected_points) <= 2)


class _MemoryStore:
    """Stands in for bench.run.store.ResultsStore's read_table/write_table (KeyError for a missing table)."""

    def __init__(self) -> None:
        self.tables: dict[str, pd.DataFrame] = {}

    def read_table(self, name: str) -> pd.DataFrame:
        return self.tables[name]

    def write_table(self, name: str, frame: pd.DataFrame) -> None:
        self.tables[name] = frame


def test_ensure_studies_computes_missing_tables_once_and_reads_them_back() -> None:
    small = {
        "study_long_time_energy": LongTimeEnergyConfig(model="linear", duration_s=60.0, n_out=31,
                                                       runs=(("verlet", 0.2),)),
        "study_stability": StabilitySweepConfig(steps=20, kh=(0.5,)),
        "study_precession_latitude": PrecessionLatitudeConfig(duration_s=120.0, n_latitudes=3),
        "study_release_azimuth": ReleaseAzimuthConfig(latitudes_deg=(40.44,), azimuths_deg=(0.0,), duration_s=60.0),
        "study_long_time_roundoff": RoundoffConfig(integrators=("verlet",), max_decade=4, releases=2),
        "study_seed": SeedConfig(duration_s=10.0),
    }
    store = _MemoryStore()
    first = ensure_studies(store, configs=small, progress=False)
    assert set(first) == set(STUDIES) == set(store.tables)
    sentinel = store.tables["study_stability"].assign(kh=-1.0)
    store.tables["study_stability"] = sentinel
    again = ensure_studies(store, configs=small, progress=False)
    assert (again["study_stability"]["kh"] == -1.0).all()  # read back, not recomputed
    recomputed = ensure_studies(store, recompute=True, configs=small, progress=False)
    pd.testing.assert_frame_equal(recomputed["study_stability"], first["study_stability"])  # deterministic
    in_workers = ensure_studies(None, configs=small, progress=False, jobs=2)  # side by side, in worker processes
    assert list(in_workers) == list(STUDIES)
    for name, table in first.items():
        pd.testing.assert_frame_equal(in_workers[name], table)


def test_the_parts_of_a_split_study_make_up_its_table_row_for_row() -> None:
    """A study computed in parts (``Study.split``, in worker processes) has the table it has computed whole, bit
    for bit: configs of several parts each (a failing run among them), for every study that has parts."""
    several = {
        "study_long_time_energy": LongTimeEnergyConfig(model="linear", duration_s=60.0, n_out=31,
                                                       runs=(("verlet", 0.2), ("dopri5", 1e-6), ("not_registered", 0.1),
                                                             ("explicit_euler", 0.5))),
        "study_stability": StabilitySweepConfig(steps=20, kh=(0.5, 2.5)),  # every fixed-step integrator
        "study_precession_latitude": PrecessionLatitudeConfig(duration_s=120.0, n_latitudes=3),
        "study_release_azimuth": ReleaseAzimuthConfig(latitudes_deg=(40.44, -0.18, 90.0), azimuths_deg=(0.0, 90.0),
                                                      duration_s=60.0, integrators=("verlet", "implicit_midpoint")),
        "study_long_time_roundoff": RoundoffConfig(integrators=("verlet", "yoshida4", "gauss_legendre4"),
                                                   max_decade=4, releases=2),
        "study_seed": SeedConfig(duration_s=10.0),
    }
    split = {name for name, study in STUDIES.items() if study.parts is not None}
    assert split and all(len(STUDIES[name].split(several[name])) >= 3 for name in split)
    whole = ensure_studies(None, configs=several, progress=False)
    in_parts = ensure_studies(None, configs=several, progress=False, jobs=2)
    for name in STUDIES:
        pd.testing.assert_frame_equal(in_parts[name], whole[name], check_exact=True)


def test_a_failing_part_raises_at_its_lookup_and_leaves_no_worker_behind(monkeypatch: pytest.MonkeyPatch) -> None:
    """A part that raises in a worker process raises where its study's table is looked up, and leaving
    ``StudyTables`` stops its workers (a failed report leaves no process behind)."""
    import multiprocessing

    from foucault_bench.bench.studies import Study, StudyTables, stored

    def compute(config: object, progress: bool) -> pd.DataFrame:
        if config == "bad":
            raise ValueError("the part 'bad' failed")
        return pd.DataFrame({"part": [config]})

    split = Study("study_in_parts", compute, ("good", "bad", "also good"), parts=list)
    monkeypatch.setattr(stored, "STUDIES", {split.name: split})  # the forked workers see it too
    before = set(multiprocessing.active_children())
    with pytest.raises(ValueError, match="the part 'bad' failed"):
        with StudyTables(None, progress=False, jobs=2) as tables:
            tables["study_in_parts"]
    assert set(multiprocessing.active_children()) <= before


def test_a_stored_study_of_another_version_is_recomputed() -> None:
    """A table stored before the release-azimuth study kept the step taken (no ``study_version`` column: version
    1) is not shown as the current study: it is recomputed, and the new table says its version."""
    from foucault_bench.bench.studies import STUDY_VERSION_COLUMN, stored_studies

    small = {
        "study_long_time_energy": LongTimeEnergyConfig(model="linear", duration_s=60.0, n_out=31,
                                                       runs=(("verlet", 0.2),)),
        "study_stability": StabilitySweepConfig(steps=20, kh=(0.5,)),
        "study_precession_latitude": PrecessionLatitudeConfig(duration_s=120.0, n_latitudes=3),
        "study_release_azimuth": ReleaseAzimuthConfig(latitudes_deg=(40.44,), azimuths_deg=(0.0,), duration_s=60.0,
                                                      integrators=("verlet",)),
        "study_long_time_roundoff": RoundoffConfig(integrators=("verlet",), max_decade=4, releases=2),
        "study_seed": SeedConfig(duration_s=10.0),
    }
    store = _MemoryStore()
    current = ensure_studies(store, configs=small, progress=False)
    old_table = current["study_release_azimuth"].drop(columns=[STUDY_VERSION_COLUMN, "kh_requested"]).assign(kh=0.1)
    store.tables["study_release_azimuth"] = old_table
    store.tables["study_stability"] = current["study_stability"].assign(kh=-1.0)  # current version, marked
    # what StudyTables reads and what the report's read-only note counts as stored (bench.studies.stored_studies)
    assert "study_release_azimuth" not in stored_studies(store) and "study_stability" in stored_studies(store)
    assert stored_studies(store, recompute=True) == {}
    again = ensure_studies(store, configs=small, progress=False)
    assert (again["study_release_azimuth"][STUDY_VERSION_COLUMN] == STUDIES["study_release_azimuth"].version).all()
    assert (again["study_release_azimuth"]["kh"] < 0.1).all()
    assert (again["study_stability"]["kh"] == -1.0).all()  # a table of the current version is read back


def test_precession_study_runs_on_a_model_that_reads_fewer_parameters() -> None:
    """The linear model never reads the centrifugal switch, so heyoka takes one parameter fewer than the vector
    holds (``Model.heyoka_parameters``); its swing plane turns at exactly −Ω_E sin φ (the closed form)."""
    config = PrecessionLatitudeConfig(model="linear", duration_s=300.0, n_latitudes=3, amplitude_m=1.0, length_m=10.0)
    table = precession_vs_latitude(config, progress=False)
    tolerance = 3.0 * table["rate_stderr_rad_s"] + 1e-9 * SIDEREAL_EARTH_RATE_RAD_S
    assert np.all(np.abs(table["rate_rad_s"] - table["textbook_rate_rad_s"]) <= tolerance)


# --------------------------------------------------------------------------------------------------------------
# the study texts of the report, recomputed from the study tables
# --------------------------------------------------------------------------------------------------------------
def _study_paragraphs(tables: dict[str, pd.DataFrame], tmp_path) -> list[str]:
    """The paragraphs the report writes for these study tables (``reports.study_sections.studies``)."""
    import pandas as pd

    from foucault_bench.reports.builder import Builder, ReportInputs
    from foucault_bench.reports.document import Paragraph
    from foucault_bench.reports.study_sections import studies

    builder = Builder(tmp_path, progress=False, interactive=False)
    studies(builder, ReportInputs(runs=pd.DataFrame(), studies=tables))
    return [block.text for page in builder.pages for block in page.blocks if isinstance(block, Paragraph)]


def _built_in_families() -> set[str]:
    return {REGISTRY[name].family for name in built_in_names()}


def test_one_and_only_one_representative_per_built_in_family() -> None:
    representatives = family_representatives()
    assert set(representatives) == _built_in_families()
    assert all(REGISTRY[name].family == family for family, name in representatives.items())
    assert len(set(representatives.values())) == len(representatives)
    chosen = [name for name, _ in LongTimeEnergyConfig().chosen_runs()]
    assert sorted(chosen) == sorted(representatives.values())  # the study's default runs are exactly these
    assert sorted({REGISTRY[name].family for name in chosen}) == sorted(_built_in_families())
    for name, setting in LongTimeEnergyConfig().chosen_runs():
        assert setting == (LongTimeEnergyConfig.tol if REGISTRY[name].adaptive else LongTimeEnergyConfig.kh)


def test_a_new_built_in_family_gets_its_representative() -> None:
    """Nothing lists the families: an integrator of a new family in the package's namespace is chosen."""
    from foucault_bench.integrators import register, unregister

    verlet_class = type(REGISTRY["verlet"])
    new_class = type("NewFamilyVerlet", (verlet_class,), {"name": "test_new_family_member", "family": "test-family",
                                                          "__module__": "foucault_bench.integrators.test_new_family"})
    register(new_class)
    try:
        assert family_representatives()["test-family"] == "test_new_family_member"
        assert family_representatives()["verlet"] == "verlet"
    finally:
        unregister("test_new_family_member")


ENERGY_TEXT_CONFIG = LongTimeEnergyConfig(model="linear", length_m=10.0, amplitude_m=0.5, duration_s=1200.0, n_out=401)


def _recomputed_trend(run: pd.DataFrame, horizon_s: float) -> tuple[float, float, float, float]:
    """(largest |error| up to horizon_s, up to the end, fitted exponent of the running maximum from horizon_s
    on, last finite time), from the table's rows."""
    run = run.sort_values("t_s")
    finite = run[run["energy_rel_error"].notna()]
    error = finite["energy_rel_error"].abs().to_numpy()
    t_s = finite["t_s"].to_numpy()
    running = np.maximum.accumulate(np.maximum(error, np.finfo(float).eps))
    late = t_s >= horizon_s
    design = np.column_stack([np.log(t_s[late]), np.ones(np.count_nonzero(late))])
    exponent = np.linalg.lstsq(design, np.log(running[late]), rcond=None)[0][0] if late.sum() >= 2 else math.nan
    return float(error[t_s <= horizon_s].max()), float(error.max()), float(exponent), float(t_s[-1])


def test_the_long_time_energy_text_states_what_its_table_shows(tmp_path) -> None:
    """Every run of the table is named once in the text, with the largest error after the first hour (here half
    the 1200-s run) and at the end, the fitted exponent and the class it implies, as recomputed here from the
    table; a diverged run is said to diverge where its finite rows end."""
    from foucault_bench.bench.studies import BOUNDED_BELOW_EXPONENT, GROWING_ABOVE_EXPONENT

    table = long_time_energy(ENERGY_TEXT_CONFIG, progress=False)
    assert sorted(table["family"].unique()) == sorted(_built_in_families())
    paragraphs = _study_paragraphs({"study_long_time_energy": table}, tmp_path)
    assert "one representative per integrator family" in paragraphs[0]
    assert "the fixed-step ones at kh = 0.05 and the adaptive ones at tol = 1e-12" in paragraphs[0]
    measured = next(text for text in paragraphs if text.startswith("What the runs show"))
    assert "round-off" not in measured
    horizon_s = ENERGY_TEXT_CONFIG.duration_s / 2
    claims = measured.split("Per run: ", 1)[1].rstrip(".").split("; ")
    assert len(claims) == table.groupby(["integrator", "setting"]).ngroups
    number = r"(-?[0-9.]+(?:e[+-]\d+)?)"
    for (integrator, setting), run in table.groupby(["integrator", "setting"]):
        label = f"{integrator} ({run['family'].iloc[0]}, {setting})"
        [claim] = [claim for claim in claims if claim.startswith(label + " ")]
        early, end, exponent, last_s = _recomputed_trend(run, horizon_s)
        status = run["status"].iloc[0]
        if status == "diverged":
            match = re.fullmatch(re.escape(label) + rf" diverged after {number} s, its error having reached {number}",
                                 claim)
            assert match, claim
            assert float(match[1]) == pytest.approx(last_s, rel=1e-9) and match[2] == f"{end:.2g}"
            continue
        assert status == "ok"
        match = re.fullmatch(re.escape(label) + rf" (bounded|drifting|growing): M = {number} by 600 s, {number} by "
                             rf"1200 s \(p = {number}\)", claim)
        assert match, claim
        assert match[2] == f"{early:.2g}" and match[3] == f"{end:.2g}"
        assert float(match[4]) == pytest.approx(exponent, abs=0.0051)
        expected = ("bounded" if exponent < BOUNDED_BELOW_EXPONENT
                    else "growing" if exponent > GROWING_ABOVE_EXPONENT else "drifting")
        assert match[1] == expected, (claim, exponent)


AZIMUTH_TEXT_CONFIG = ReleaseAzimuthConfig(latitudes_deg=(40.44, -0.18), azimuths_deg=(0.0, 90.0), duration_s=200.0)


@pytest.fixture(scope="module")
def azimuth_table() -> pd.DataFrame:
    return precession_vs_release_azimuth(AZIMUTH_TEXT_CONFIG, progress=False)


def test_the_release_azimuth_study_holds_the_structure_preserving_integrators_only() -> None:
    """Chosen from the declared facts: every built-in fixed-step integrator with a volume-preserving one-step
    map (symplectic ones included), not RK4."""
    expected = {name for name in built_in_names()
                if not REGISTRY[name].adaptive and (REGISTRY[name].volume_preserving or REGISTRY[name].symplectic)}
    assert set(ReleaseAzimuthConfig().integrators) == expected
    assert "rk4" not in expected and {"verlet", "boris", "implicit_midpoint"} <= expected


def test_the_release_azimuth_table_holds_the_step_taken(azimuth_table: pd.DataFrame) -> None:
    """kh 0.1 on the 0.45-s grid runs as 9 steps of 0.05 s per interval: the table says kh = k·0.05 s."""
    for latitude, rows in azimuth_table.groupby("latitude_deg"):
        params = PendulumParameters(length_m=AZIMUTH_TEXT_CONFIG.length_m, latitude_deg=latitude,
                                    amplitude_m=AZIMUTH_TEXT_CONFIG.amplitude_m)
        k = params.pendulum_frequency_rad_s
        grid = AZIMUTH_TEXT_CONFIG.output_interval_s * np.arange(3)
        _, step_s = uniform_output_stride(grid, AZIMUTH_TEXT_CONFIG.kh / k)
        assert step_s == pytest.approx(0.05, rel=1e-12)
        assert np.allclose(rows["kh"], k * step_s, rtol=1e-12, atol=0.0)
        assert (rows["kh_requested"] == AZIMUTH_TEXT_CONFIG.kh).all()


def test_the_release_azimuth_text_states_the_law_at_the_step_taken(azimuth_table: pd.DataFrame, tmp_path) -> None:
    """The implicit midpoint rule's error predicted in the text, (kh)²/4 of the local rate, is within 2 % of the
    error measured at each latitude (median over the azimuths, recomputed here from the table), and the text
    lists exactly the table's integrators and the step they took."""
    [text] = [paragraph for paragraph in _study_paragraphs({"study_release_azimuth": azimuth_table}, tmp_path)
              if "study `study_release_azimuth`" in paragraph]
    names = sorted(azimuth_table["integrator"].unique())
    assert f"`volume_preserving`, implied by `symplectic`: {', '.join(names)})" in text
    kh_taken = float(azimuth_table["kh"].iloc[0])
    assert f"at kh = {kh_taken:.4g} ({AZIMUTH_TEXT_CONFIG.kh:g} requested" in text
    assert f"(kh)²/4 = {kh_taken**2 / 4:.3g}," in text
    predicted = dict(re.findall(r"([0-9.e+-]+) Ω_E at (-?[0-9.]+)°", text.split("which predicts ")[1].split(";")[0]))
    predicted = {float(latitude): float(value) for value, latitude in predicted.items()}
    assert set(predicted) == set(AZIMUTH_TEXT_CONFIG.latitudes_deg)
    midpoint = azimuth_table[azimuth_table["integrator"] == "implicit_midpoint"]
    for latitude, rows in midpoint.groupby("latitude_deg"):
        assert (rows["status"] == "ok").all()
        measured = rows["error_earth"].median()
        local_rate_earth = (rows["reference_rate_rad_s"].abs() / SIDEREAL_EARTH_RATE_RAD_S).median()
        assert predicted[latitude] == pytest.approx(kh_taken**2 / 4 * local_rate_earth, rel=5e-3)  # 3 digits
        assert predicted[latitude] == pytest.approx(measured, rel=0.02), latitude
