"""The seed note revisited (bench.studies.seed_revisited, reports.seed): the numbers behind each finding follow
from the theory quoted in the finding, and `foucault-bench seed` writes its figures and text."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.studies import SeedStudy, seed_revisited, seed_series, seed_study
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S


@pytest.fixture(scope="module")
def study() -> SeedStudy:
    return seed_revisited()


def _a_over_k(study: SeedStudy) -> float:
    c = study.config
    a = study.numbers["solar_day_rate_rad_s"] * math.sin(math.radians(c.latitude_deg))
    return a / math.sqrt(9.81 / c.length_m)


def test_explicit_euler_energy_grows_as_one_plus_kh_squared_to_the_n(study: SeedStudy) -> None:
    n = study.numbers
    measured = 1.0 + n["euler_energy_final"]
    theory = 1.0 + n["euler_energy_theory_final"]
    # Coriolis splits the modes' growth factors to 1 + h²(Ω ∓ a)² (factor exp(±2(a/k)·n(kh)²) on the
    # ratio), and eqs. 4-5 change the energy by themselves (model_energy_max): allow twice the first plus the second.
    tolerance = 4.0 * _a_over_k(study) * n["euler_steps"] * n["kh"] ** 2 + n["model_energy_max"]
    assert abs(measured / theory - 1.0) <= tolerance
    assert n["euler_energy_final"] > 0.1  # 12 % in 2 minutes: growing, not a bounded oscillation
    series = study.series["euler_energy_rel_error"].to_numpy()
    assert np.all(np.diff(series[::200]) > 0)  # monotone growth, sampled every 10 s


def test_the_euler_swing_widens_as_its_energy_says(study: SeedStudy) -> None:
    n = study.numbers
    amplitude = study.config.amplitude_m
    # the energy ½v² + ½k²r² grows by (1 + (kh)²) per step, so the swing's reach grows as its square root
    # (compared at the grid time of the largest |r| in the last swing); that grid point misses the true turning
    # point by at most A(1 − cos(kΔt/2)), and the tolerance on the energy growth (see above) carries over halved
    k = math.sqrt(9.81 / study.config.length_m)
    sampling = amplitude * (1.0 - math.cos(k * study.config.output_spacing_s / 2.0))
    growth = 2.0 * _a_over_k(study) * n["euler_steps"] * n["kh"] ** 2 + n["model_energy_max"]
    assert abs(n["euler_amplitude_end_m"] - n["euler_amplitude_theory_end_m"]) <= (
        sampling + growth * n["euler_amplitude_theory_end_m"])
    assert n["euler_amplitude_end_m"] > 1.05 * amplitude
    # Verlet on the same equations: the reach stays A, to within the grid sampling and the model's energy change
    assert abs(n["verlet_amplitude_end_m"] - amplitude) <= sampling + n["model_energy_max"] * amplitude


def test_symplectic_euler_is_the_bounded_one(study: SeedStudy) -> None:
    n = study.numbers
    # symplectic Euler keeps the quadratic form ½v² + ½k²x² − (h k²/2)·x·v: E/E₀ stays within
    # (1 ± kh/2)/(1 ∓ kh/2), i.e. |ΔE/E₀| ≤ kh/(1 − kh/2) (Hairer, Lubich & Wanner, GNI §I.1), plus the
    # model's own change
    assert n["symplectic_energy_max"] <= n["kh"] / (1.0 - n["kh"] / 2.0) + n["model_energy_max"]
    late = study.series["symplectic_energy_rel_error"].abs().to_numpy()
    half = len(late) // 2
    assert late[half:].max() <= 1.01 * late[:half].max() + n["model_energy_max"]  # no growth in the second minute


def test_the_seed_model_changes_its_energy_by_the_tension_term(study: SeedStudy) -> None:
    n = study.numbers
    assert n["model_energy_max"] > 1e-7  # eqs. 4-5 really do not conserve E
    # trapezoid rule on a 0.05 s grid for an integrand oscillating at up to 3k: relative error ≤ (3kΔt)²/12
    k = math.sqrt(9.81 / study.config.length_m)
    tolerance = (3.0 * k * study.config.output_spacing_s) ** 2 / 12.0 * n["model_energy_max"]
    assert n["model_energy_formula_mismatch"] <= tolerance


def test_the_approximation_gap_meets_its_bound_and_the_difference_is_eulers(study: SeedStudy) -> None:
    n = study.numbers
    # seed_gap_bound is the leading order in a/k of the gap: the maxima agree to O(a/k)
    assert abs(n["approximation_gap_max_m"] / n["approximation_gap_bound_max_m"] - 1.0) <= 10.0 * _a_over_k(study)
    # the seed's "difference of order 1e-2" is explicit Euler's own error, not physics
    assert 1e-3 < n["seed_difference_max_m"] < 1e-1
    assert abs(n["euler_error_max_m"] / n["seed_difference_max_m"] - 1.0) < 0.01
    physics = n["approximation_gap_max_m"] + n["model_difference_max_m"] + n["day_length_difference_max_m"]
    assert physics < 0.01 * n["seed_difference_max_m"]


def test_solar_day_and_centrifugal_slip(study: SeedStudy) -> None:
    n = study.numbers
    # 1 − (2π/86400 s)/Ω_E with the sidereal day 86164.0905 s (Ω_E is stored to 8 digits: rel 1e-5)
    assert n["day_rate_shortfall"] == pytest.approx(1.0 - 86164.0905 / 86400.0, rel=1e-5)
    assert n["sidereal_rate_rad_s"] == SIDEREAL_EARTH_RATE_RAD_S
    w2 = n["solar_day_rate_rad_s"] ** 2
    colatitude = math.radians(90.0 - study.config.latitude_deg)
    # −ω×(ω×r) = Ω²(x cos²λ, y, x sin λ cos λ) for r = (x, y, 0): the seed's −yω² has the wrong sign
    assert n["centrifugal_correct_y_m_s2"] == pytest.approx(n["centrifugal_y_m"] * w2, rel=1e-12)
    assert n["centrifugal_seed_y_m_s2"] == pytest.approx(-n["centrifugal_correct_y_m_s2"], rel=1e-12)
    assert n["centrifugal_correct_x_m_s2"] == pytest.approx(n["centrifugal_x_m"] * w2 * math.cos(colatitude) ** 2,
                                                            rel=1e-12)
    assert n["centrifugal_over_gravity"] < 1e-9  # negligible, as the seed says


def test_seed_command_writes_figures_and_findings(tmp_path: Path, study: SeedStudy, monkeypatch) -> None:
    import foucault_bench.reports.seed as seed_module

    monkeypatch.setattr(seed_module, "seed_revisited", lambda: study)  # computed once, by the fixture
    assert cli_main(["seed", "--out", str(tmp_path)]) == 0
    for name in ("trajectory", "euler", "energy", "difference"):
        for suffix in ("png", "svg"):
            assert (tmp_path / "figures" / f"seed_{name}.{suffix}").stat().st_size > 1000
    text = (tmp_path / "SEED.md").read_text(encoding="utf-8")
    assert text.count("**Does not hold:**") == 2 and "**Sign slip:**" in text and "0.27 %" in text
    assert "figures/seed_energy.png" in (tmp_path / "index.html").read_text(encoding="utf-8")


def test_the_stored_seed_table_gives_the_same_study(tmp_path: Path, study: SeedStudy) -> None:
    """The report draws the seed section from the table ``study_seed`` stored in the results database
    (``bench.studies.STUDIES``): read back, it gives the study computed directly, its config, series and numbers
    bit for bit."""
    with ResultsStore(tmp_path / "results.sqlite") as store:
        store.write_table("study_seed", seed_series())
        stored = seed_study(store.read_table("study_seed"))
    assert stored.config == study.config
    pd.testing.assert_frame_equal(stored.series, study.series, check_exact=True)
    assert stored.numbers.keys() == study.numbers.keys()
    assert all(np.float64(stored.numbers[name]).tobytes() == np.float64(study.numbers[name]).tobytes()
               for name in study.numbers)


def test_the_report_s_seed_figures_are_static_files_only_with_static(tmp_path: Path, study: SeedStudy) -> None:
    """Like every chart of the report, the seed section's four charts get their PNG and SVG under the report's
    folder only when the report is built with ``--static``; without it their blocks say so (REPORT.md then
    links the interactive chart)."""
    from foucault_bench.reports.document import Figure
    from foucault_bench.reports.seed import seed_blocks

    interactive_only = [b for b in seed_blocks(tmp_path / "a", "seed", study, static=False) if isinstance(b, Figure)]
    assert len(interactive_only) == 4 and not any(figure.static for figure in interactive_only)
    assert all(figure.interactive for figure in interactive_only) and not (tmp_path / "a").exists()
    static = [b for b in seed_blocks(tmp_path / "b", "seed", study, static=True) if isinstance(b, Figure)]
    assert [figure.stem for figure in static] == [figure.stem for figure in interactive_only]
    for figure in static:
        assert figure.static
        for suffix in ("png", "svg"):
            assert (tmp_path / "b" / f"{figure.stem}.{suffix}").stat().st_size > 1000
