"""The report's page of the studies (``bench.studies``, tables read from the database): long-time energy,
stability, precession against latitude and against the release direction, each with its chart, its summary
table and what the runs show, and the seed note revisited (``reports.seed``).
"""

from __future__ import annotations

from functools import partial

import pandas as pd

from foucault_bench.bench.studies import (
    BOUNDED_BELOW_EXPONENT,
    GROWING_ABOVE_EXPONENT,
    energy_trends,
    family_representatives,
    midpoint_precession_law,
    seed_study,
    structure_preserving_integrators,
    study_setting_label,
)
from foucault_bench.integrators import REGISTRY, STATUS_OK
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S
from foucault_bench.reports import study_charts, tables
from foucault_bench.reports.builder import Builder, ReportInputs
from foucault_bench.reports.chart_style import LOG_FLOOR
from foucault_bench.reports.document import Heading, Paragraph
from foucault_bench.reports.roundoff import roundoff_growth
from foucault_bench.reports.seed import seed_blocks

STUDIES_PAGE = "studies.html"


def studies(builder: Builder, inputs: ReportInputs) -> None:
    """The studies page: each stored study table's chart, summary and findings."""
    studies = inputs.studies
    if studies:
        builder.page(STUDIES_PAGE, "studies")

    def span(seconds: float) -> str:
        return f"{seconds / 3600:g} h" if seconds >= 3600 else f"{seconds:g} s"

    energy = studies.get("study_long_time_energy")
    if energy is not None:
        first = energy.iloc[0]
        trends = energy_trends(energy)
        horizon = span(float(trends["early_horizon_s"].iloc[0]))
        end = span(float(first["config_duration_s"]))
        shown = set(zip(trends["integrator"], trends["setting"], strict=True))
        if {"config_kh", "config_tol"} <= set(energy.columns) and shown == {
                (name, study_setting_label(name, first["config_tol"] if REGISTRY[name].adaptive else first["config_kh"]))
                for name in family_representatives().values()}:
            which = ("one representative per integrator family, each family's simplest built-in member by the "
                     "facts it declares (fixed-step before adaptive, then the lowest order, then compiled code; "
                     "bench.studies.family_representatives), the fixed-step ones at "
                     f"kh = {first['config_kh']:g} and the adaptive ones at tol = {first['config_tol']:g}")
        else:
            which = f"{len(trends)} configured runs"
        clauses = []
        for run in trends.itertuples():
            label = f"{run.integrator} ({run.family}, {run.setting})"
            if run.trend == "failed":
                clauses.append(f"{label} failed (its message is in the table below)")
            elif run.trend == "diverged" and pd.isna(run.last_finite_s):
                clauses.append(f"{label} diverged before the first output")
            elif run.trend == "diverged":
                clauses.append(f"{label} diverged after {run.last_finite_s:g} s, its error having reached "
                               f"{run.max_error:.2g}")
            elif pd.isna(run.exponent):
                clauses.append(f"{label}: M = {run.early_max_error:.2g} by {horizon}, {run.max_error:.2g} by "
                               f"{end} (too few outputs after {horizon} to fit a trend)")
            else:
                clauses.append(f"{label} {run.trend}: M = {run.early_max_error:.2g} by {horizon}, "
                               f"{run.max_error:.2g} by {end} (p = {round(run.exponent, 2) + 0.0:.2f})")
        builder.add(Heading("Long-time energy"), Paragraph(
            f"Relative energy error (E − E₀)/E_swing against time over {end}, {which} (study "
            "`study_long_time_energy`, bench.studies.long_time_energy). "
            f"Values below {LOG_FLOOR:g} (exact zeros included) are drawn at {LOG_FLOOR:g}."),
            Paragraph(
            f"What the runs show, with M(t) the largest |error| up to t and its trend the exponent p of "
            f"M ∝ tᵖ fitted from {horizon} to the end (bounded when p < {BOUNDED_BELOW_EXPONENT:g}, growing when "
            f"p > {GROWING_ABOVE_EXPONENT:g}, drifting in between). Per run: " + "; ".join(clauses) + "."))
        builder.curves("study_long_time_energy",
                       "Relative energy error against time (log-log), per integrator family. Thick line: the largest "
                       "error so far (its running maximum), which separates bounded, drifting and growing errors; "
                       "faint line of the same colour: the error at each output time, whose oscillation the "
                       "maximum hides (a symplectic method's error swings within a band every half period).",
                       study_charts.long_time_energy, energy)
        builder.table(tables.long_time_summary(energy), "study_long_time_energy_summary",
                      "Long-time energy: error after the first hour and at the end")
    roundoff = studies.get("study_long_time_roundoff")
    if roundoff is not None:
        builder.add(Heading("Long-time round-off"), Paragraph(
            "On the linear model each symmetric scheme's one-step map conserves a quadratic form Q (the energy "
            "for the Gauss-Legendre methods), so its drift is round-off alone (study `study_long_time_roundoff`, "
            "bench.studies.long_time_roundoff; integrators/README.md \"Round-off over long runs\")."))
        builder.curves("study_long_time_roundoff",
                       f"|ΔQ|/Q against steps at kh = {roundoff['kh'].iloc[0]:g}: per integrator the median over "
                       f"{int(roundoff['config_releases'].iloc[0])} random releases (bars: their range) and the "
                       "fitted growth exponent; dashed: ε√n.",
                       roundoff_growth, roundoff)
    stability = studies.get("study_stability")
    if stability is not None:
        builder.add(Heading("Stability"), Paragraph(
            f"Every fixed-step integrator on the linear model at each k·h, without Earth's rotation and with it "
            f"(study `study_stability`): the max relative energy error over a run of "
            f"{int(stability['config_steps'].iloc[0])} steps, and the growth per step of the scheme's own one-step "
            "map (max |λ| − 1), from which the measured limit is bisected. The dashed line is the limit each "
            "integrator declares on the undamped oscillator (`stability_limit_kh`); a method whose declared limit "
            "holds only without rotation declares its growth law with rotation, drawn against the measurement "
            "in the second chart. At exactly kh = 2 Verlet's and symplectic Euler's oscillator matrices have the "
            "double eigenvalue −1: the amplitude grows linearly rather than exponentially, which is why the "
            "curves dip or end there."))
        builder.curves("study_stability", "Energy error against k·h across each fixed-step integrator's stability "
                       "limit, without rotation (solid) and with it (dashed); triangles mark the measured limits.",
                       study_charts.stability, stability)
        builder.curves("study_stability_rotation_growth",
                       "Growth per step with Earth's rotation: measured one-step growth against the declared law.",
                       study_charts.rotation_growth, stability)
        builder.table(tables.stability_summary(stability), "study_stability_summary",
                      "Stability: declared and measured limits, first divergence, growth with rotation")
    precession = studies.get("study_precession_latitude")
    if precession is not None:
        residual = (precession["rate_rad_s"] - precession["airy_rate_rad_s"]).abs().max() / SIDEREAL_EARTH_RATE_RAD_S
        first = precession.iloc[0]
        builder.add(Heading("Precession against latitude"), Paragraph(
            f"Measured precession rate at {len(precession)} latitudes ({first['config_model']} model, one heyoka "
            "Taylor batch integrator, one batch element per latitude; study `study_precession_latitude`) against "
            "the textbook −Ω_E sin φ. The residual follows the Airy correction (3/8)θ₀² of the finite swing "
            f"(θ₀ = A/L = {first['config_amplitude_m'] / first['config_length_m']:.3g}); the largest distance from "
            f"it is {residual:.2g} Ω_E (release-side terms, docs/models/README.md \"Airy precession\")."))
        builder.curves("study_precession_latitude",
                       "Precession rate against latitude; residual from −Ω_E sin φ in units of Ω_E.",
                       study_charts.precession_latitude, precession)

    azimuth = studies.get("study_release_azimuth")
    if azimuth is not None:
        first = azimuth.iloc[0]
        names = sorted(azimuth["integrator"].unique())
        declared = [name for name in names if name in REGISTRY and REGISTRY[name].describe()["volume_preserving"]]
        if names == sorted(structure_preserving_integrators()):
            members = ("Every built-in fixed-step integrator that declares a volume-preserving one-step map "
                       f"(`volume_preserving`, implied by `symplectic`: {', '.join(names)})")
        elif declared == names:
            members = (f"The integrators {', '.join(names)}, each declaring a volume-preserving one-step map "
                       "(`volume_preserving`)")
        else:
            members = f"The integrators {', '.join(names)}"
        ok = azimuth[azimuth["status"] == STATUS_OK]
        taken = sorted(ok["kh"].unique()) if not ok.empty else sorted(azimuth["kh"].dropna().unique())
        requested = float(first["kh_requested"])
        step = " and ".join(f"{kh:.4g}" for kh in taken) or "–"
        if any(kh != requested for kh in taken):
            step += (f" ({requested:g} requested, shortened so that whole steps fill each "
                     f"{first['config_output_interval_s']:g} s output interval)")
        latitudes = sorted(azimuth["latitude_deg"].unique(), reverse=True)
        text = (f"{members}, at kh = {step} on the {first['config_model']} model, released at azimuths from "
                f"South (0°, a North-South swing) to North, at {', '.join(f'{lat:g}°' for lat in latitudes)} "
                "(study `study_release_azimuth`); the error is the rate's distance from heyoka's at "
                f"tol = {first['config_reference_tol']:g} on the same grid, relative to Ω_E so that latitudes "
                "compare.")
        verlet = ok[ok["integrator"] == "verlet"]
        if not verlet.empty:
            extremes = []
            north_south_worst = True
            for latitude in latitudes:
                sweep = verlet[verlet["latitude_deg"] == latitude].set_index("release_azimuth_deg")["error_earth"]
                worst, best = float(sweep.idxmax()), float(sweep.idxmin())
                north_south_worst &= min(worst, 180.0 - worst) <= 15.0 and abs(best - 90.0) <= 15.0
                extremes.append(f"at {latitude:g}° from {sweep.min():.2g} Ω_E (released at {best:g}°) to "
                                f"{sweep.max():.2g} Ω_E ({worst:g}°)")
            text += " Verlet's error depends on the direction: " + ", ".join(extremes) + "."
            if north_south_worst:
                text += (" A North-South swing feels the horizontal part of ω along its own line, which an "
                         "East-West release (every real scene's) hides.")
        law = midpoint_precession_law(azimuth)
        if not law.empty:
            by_latitude = law.sort_values("latitude_deg", ascending=False).set_index("latitude_deg")
            law_kh = " and ".join(f"{kh * kh / 4:.3g}" for kh in sorted(by_latitude["kh"].unique()))
            text += (" The implicit midpoint rule is slow by (kh)²/4 of the local rate whatever the direction: "
                     "its Cayley map turns each circular mode too slowly, and the precession is their mean. At "
                     f"the step taken (kh)²/4 = {law_kh}, which predicts "
                     + ", ".join(f"{row.law_error_earth:.3g} Ω_E at {lat:g}°" for lat, row in by_latitude.iterrows())
                     + "; measured (median over the azimuths) "
                     + ", ".join(f"{row.measured_error_earth:.3g} Ω_E at {lat:g}°"
                                 for lat, row in by_latitude.iterrows())
                     + ", varying with the azimuth by at most "
                     + f"{100 * by_latitude['azimuth_variation'].max():.2g} %.")
        builder.add(Heading("Precession error against the release direction"), Paragraph(text))
        builder.curves("study_release_azimuth",
                       "Precession-rate error relative to Ω_E against the release azimuth, per latitude.",
                       study_charts.release_azimuth, azimuth)


def seed_section(builder: Builder, inputs: ReportInputs) -> None:
    """The seed note revisited, on the studies page: the study ``study_seed`` drawn by ``reports.seed``."""
    table = inputs.studies.get("study_seed")
    if table is not None:
        builder.page(STUDIES_PAGE, "studies")
        builder.later("seed section", partial(seed_blocks, builder.folder, "seed", seed_study(table), builder.static),
                      long=True, key=(table, builder.static))
