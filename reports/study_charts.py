"""The report's static charts of the study tables (``bench.studies``): long-time energy, stability and growth with
rotation, precession against latitude and against the release direction, and model adequacy. Each function reads
one table and returns a matplotlib figure; the report saves it (``chart_style.save``) and converts it for the page
(``reports.plotly_conversion.from_matplotlib``). Conventions: ``reports.chart_style``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from foucault_bench.integrators import STATUS_DIVERGED, STATUS_FAILED, STATUS_OK
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S
from foucault_bench.reports.chart_style import (
    DIVERGED_MARKER,
    FAILED_MARKER,
    LOG_FLOOR,
    family_colour,
    integrator_style,
    mark_on_edge,
    number_text,
    ordered_integrators,
    outcome_legend_handles,
    set_log_scales,
)


def long_time_energy(table: pd.DataFrame) -> Figure:
    """|E − E₀|/E_swing against time on log-log axes, one run of the long-time energy study per colour: the
    largest value so far (bold) over the values themselves (faint), so that bounded, drifting and growing
    errors read apart."""
    figure = Figure(figsize=(11, 5.6), layout="constrained")
    axes = figure.subplots()
    handles = []
    for integrator, family in ordered_integrators(table):
        rows = table[table["integrator"] == integrator]
        style = integrator_style(integrator, family)
        status = rows["status"].iloc[0]
        t = rows["t_s"].to_numpy(dtype=float)
        error = np.abs(rows["energy_rel_error"].to_numpy(dtype=float))
        finite = np.isfinite(error)
        label = f"{integrator} ({rows['setting'].iloc[0]})" + ("" if status == STATUS_OK else f": {status}")
        shown = np.maximum(error[finite], LOG_FLOOR)
        axes.plot(t[finite], shown, color=style["color"], linestyle="-", linewidth=0.5, alpha=0.25)
        (line,) = axes.plot(t[finite], np.maximum.accumulate(shown) if shown.size else shown, label=label,
                            color=style["color"], linestyle=style["linestyle"], linewidth=1.8)
        handles.append(line)
        if status != STATUS_OK:
            last = t[finite][-1] if finite.any() else np.nan
            mark_on_edge(axes, np.array([last]), style["color"],
                         DIVERGED_MARKER if status == STATUS_DIVERGED else FAILED_MARKER, "top")
    set_log_scales(axes)
    axes.set_xlabel("time t (s)")
    axes.set_ylabel("relative energy error |E(t) − E₀| / E_swing")
    axes.grid(True, which="major", alpha=0.3)
    first = table.iloc[0]
    axes.set_title(f"Long-time energy: {first['config_model']} model, L = {first['config_length_m']:g} m, "
                   f"φ = {first['config_latitude_deg']:g}°, A = {first['config_amplitude_m']:g} m", pad=14)
    line_kinds = [Line2D([], [], color="grey", linewidth=1.8, label="thick: largest error so far"),
                  Line2D([], [], color="grey", linewidth=0.5, alpha=0.4, label="faint: error at each output time")]
    figure.legend(handles=handles + line_kinds + outcome_legend_handles()[:2], loc="outside right upper", fontsize=9)
    return figure


def stability(table: pd.DataFrame) -> Figure:
    """Max relative energy error over a long run against k·h, one panel per fixed-step integrator, without
    Earth's rotation (solid) and with it (dashed), with the declared limit (dashed line) and the measured one
    (triangle on the axis)."""
    integrators = ordered_integrators(table)
    columns = 2
    rows_of_panels = (len(integrators) + columns - 1) // columns
    figure = Figure(figsize=(12, 3.6 * rows_of_panels + 0.8), layout="constrained")
    # y not shared: a panel whose runs all diverge (explicit Euler) would impose its placeholder limits on all
    panels = np.atleast_1d(figure.subplots(rows_of_panels, columns, sharex=True, squeeze=False)).ravel()
    for axes, (integrator, family) in zip(panels, integrators, strict=False):  # spare panels: hidden below
        style = integrator_style(integrator, family)
        for rotation, linestyle in ((False, "-"), (True, "--")):
            rows = table[(table["integrator"] == integrator) & (table["rotation"] == rotation)].sort_values("kh")
            if rows.empty:
                continue
            x = rows["kh"].to_numpy(dtype=float)
            y = rows["energy_max_rel_error"].to_numpy(dtype=float)
            statuses = rows["status"].to_numpy()
            ok = statuses == STATUS_OK
            axes.plot(x[ok], np.maximum(y[ok], LOG_FLOOR), color=style["color"], marker=style["marker"],
                      markersize=3.5, linestyle=linestyle, alpha=1.0 if rotation else 0.6)
            mark_on_edge(axes, x[statuses == STATUS_DIVERGED], style["color"], DIVERGED_MARKER, "top")
            mark_on_edge(axes, x[statuses == STATUS_FAILED], style["color"], FAILED_MARKER, "top")
            measured = float(rows["measured_limit_kh"].iloc[0])
            if np.isfinite(measured):
                axes.plot([measured], [0.0], marker="^" if rotation else "v", color="black", markersize=7,
                          transform=axes.get_xaxis_transform(), clip_on=False, linestyle="none")
        limit = float(table.loc[table["integrator"] == integrator, "stability_limit_kh"].iloc[0])
        if np.isfinite(limit):
            axes.axvline(limit, color="black", linestyle="--", linewidth=1)
            axes.axvspan(limit, max(table["kh"].max(), limit) * 1.02, color="#d62728", alpha=0.07)
            axes.text(limit, 0.06, f" declared limit kh = {limit:.4g}", transform=axes.get_xaxis_transform(),
                      fontsize=9)
        else:
            axes.text(0.02, 0.06, "no declared limit: unstable for every h > 0", transform=axes.transAxes,
                      fontsize=9)
        set_log_scales(axes, x=False)
        axes.set_title(integrator, pad=12)
        axes.grid(True, which="major", alpha=0.3)
    for axes in panels[len(integrators):]:
        axes.set_visible(False)
    for axes in panels[::columns]:
        axes.set_ylabel("max |E − E₀| / E_swing")
    for axes in panels[-columns:]:
        axes.set_xlabel("k·h (step in units of 1/k = √(L/g))")
    first = table.iloc[0]
    handles = [Line2D([], [], color="grey", linestyle="-", label="Ω_E = 0 (no rotation)"),
               Line2D([], [], color="grey", linestyle="--", label=f"Ω_E sidereal, φ = {first['config_latitude_deg']:g}°"),
               Line2D([], [], color="black", marker="v", linestyle="none", label="measured limit, no rotation"),
               Line2D([], [], color="black", marker="^", linestyle="none", label="measured limit, rotation")]
    figure.legend(handles=handles + outcome_legend_handles()[:2], loc="outside lower center", ncols=3, fontsize=9)
    figure.suptitle(f"Stability: {int(first['config_steps'])} steps of the {first['config_model']} model at each k·h, "
                    f"L = {first['config_length_m']:g} m")
    return figure


def rotation_growth(table: pd.DataFrame) -> Figure:
    """Per-step growth of the one-step map with Earth's rotation against k·h for the integrators that declare a
    growth law (unstable at every h once the frame rotates), measured (markers) against the law (line)."""
    figure = Figure(figsize=(7.5, 4.8), layout="constrained")
    axes = figure.subplots()
    rotating = table[table["rotation"] & np.isfinite(table["growth_theory"].to_numpy(dtype=float))]
    for (integrator, family), rows in rotating.groupby(["integrator", "family"], sort=True):
        rows = rows.sort_values("kh")
        style = integrator_style(integrator, family)
        axes.plot(rows["kh"], rows["growth_theory"], color=style["color"], linestyle="-", linewidth=1.2,
                  label=f"{integrator}: ½(kh)²(a/k)/√(1 − (kh/2)²)")
        axes.plot(rows["kh"], rows["growth_per_step"], color=style["color"], marker=style["marker"],
                  linestyle="none", markersize=5, label=f"{integrator}: measured max |λ| − 1")
    set_log_scales(axes, x=False)
    axes.set_xlabel("k·h")
    axes.set_ylabel("amplitude growth per step")
    if not rotating.empty:
        axes.set_title(f"Growth with Earth's rotation (a/k = {number_text(rotating['rate_ratio'].iloc[0])})", pad=10)
        axes.legend(fontsize=9)
    axes.grid(True, which="major", alpha=0.3)
    return figure


def precession_latitude(table: pd.DataFrame) -> Figure:
    """Measured precession rate against latitude next to −Ω_E sin φ, and the residual in units of Ω_E with
    the Airy correction."""
    rows = table.sort_values("latitude_deg")
    degrees_per_hour = np.degrees(1.0) * 3600.0
    latitude = rows["latitude_deg"].to_numpy(dtype=float)
    figure = Figure(figsize=(10, 8), layout="constrained")
    top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    top.plot(latitude, rows["textbook_rate_rad_s"] * degrees_per_hour, color="black", linewidth=1,
             label="textbook −Ω_E sin φ")
    top.plot(latitude, rows["rate_rad_s"] * degrees_per_hour, "o", color=family_colour("taylor"), markersize=5,
             label="measured (heyoka Taylor batch, turning points)")
    top.set_ylabel("precession rate (°/h, counter-clockwise positive)")
    top.axhline(0.0, color="grey", linewidth=0.6)
    top.legend(fontsize=9)
    top.grid(True, alpha=0.3)
    residual = (rows["rate_rad_s"] - rows["textbook_rate_rad_s"]) / SIDEREAL_EARTH_RATE_RAD_S
    airy = (rows["airy_rate_rad_s"] - rows["textbook_rate_rad_s"]) / SIDEREAL_EARTH_RATE_RAD_S
    bottom.errorbar(latitude, residual, yerr=rows["rate_stderr_rad_s"] / SIDEREAL_EARTH_RATE_RAD_S, fmt="o",
                    color=family_colour("taylor"), markersize=4, label="measured − textbook (±1 standard error)")
    bottom.plot(latitude, airy, "--", color="black", linewidth=1, label="Airy: (3/8)θ₀² Ω_E sin φ")
    bottom.axhline(0.0, color="grey", linewidth=0.6)
    bottom.set_xlabel("latitude φ (°, north positive)")
    bottom.set_ylabel("(rate − (−Ω_E sin φ)) / Ω_E")
    bottom.legend(fontsize=9)
    bottom.grid(True, alpha=0.3)
    first = rows.iloc[0]
    figure.suptitle(f"Precession against latitude: {first['config_model']} model, L = {first['config_length_m']:g} m, "
                    f"A = {first['config_amplitude_m']:g} m, {first['config_duration_s'] / 3600:g} h per latitude")
    return figure


def release_azimuth(table: pd.DataFrame) -> Figure:
    """Precession-rate error (relative to Ω_E) against the release azimuth, one panel per latitude, one line per
    integrator (log scale)."""
    latitudes = sorted(table["latitude_deg"].unique(), reverse=True)
    figure = Figure(figsize=(12, 4.6), layout="constrained")
    panels = np.atleast_1d(figure.subplots(1, len(latitudes), sharey=True, squeeze=False)).ravel()
    handles = {}
    for axes, latitude in zip(panels, latitudes, strict=True):
        rows = table[table["latitude_deg"] == latitude]
        for (integrator, family), sweep in rows.groupby(["integrator", "family"], sort=True):
            sweep = sweep.sort_values("release_azimuth_deg")
            style = integrator_style(integrator, family)
            ok = (sweep["status"] == STATUS_OK).to_numpy()
            (line,) = axes.plot(sweep["release_azimuth_deg"].to_numpy()[ok],
                                np.maximum(sweep["error_earth"].to_numpy(dtype=float)[ok], LOG_FLOOR),
                                color=style["color"], marker=style["marker"], markersize=4, label=integrator)
            handles[integrator] = line
        set_log_scales(axes, x=False)
        axes.set_xticks(np.arange(0, 181, 45))
        axes.set_xlabel("release azimuth (° from South towards East)")
        axes.set_title(f"φ = {latitude:g}°", pad=10)
        axes.grid(True, which="major", alpha=0.3)
    panels[0].set_ylabel("|rate − reference rate| / Ω_E")
    figure.legend(handles=list(handles.values()), loc="outside right upper", fontsize=9)
    first = table.iloc[0]
    figure.suptitle(f"Precession error against release direction (0° = North-South swing, 90° = East-West): "
                    f"{first['config_model']} model, L = {first['config_length_m']:g} m, "
                    f"A = {first['config_amplitude_m']:g} m, kh = {number_text(first['kh'])}, "
                    f"{number_text(first['config_duration_s'])} s")
    return figure


def adequacy(table: pd.DataFrame) -> Figure:
    """Per scene, what each simpler model gets wrong against the richer one (``bench.verdicts.adequacy``): |precession
    rate difference| in units of Ω_E|sin φ| and trajectory gap in units of A, measured (filled) next to the
    leading-order expectation (hollow) where the physics gives one; dot plot on log axes."""
    rows = table.reset_index(drop=True)
    labels = [f"{r.scene}: {r.simpler_model} vs {r.model}" for r in rows.itertuples()]
    figure = Figure(figsize=(13, 0.42 * len(rows) + 2.0), layout="constrained")
    panels = figure.subplots(1, 2, sharey=True)
    positions = np.arange(len(rows))
    panel_columns = (
        ("precession_rate_diff", "expected_rate_diff", "|rate(simpler) − rate(richer)| / (Ω_E |sin φ|)",
         "Precession rate missed"),
        ("trajectory_gap", "expected_trajectory_gap", "max |r(simpler) − r(richer)| / A", "Path missed"),
    )
    for axes, (measured_column, expected_column, label, title) in zip(panels, panel_columns, strict=True):
        axes.set_title(title, fontsize=10)
        measured = np.abs(rows[measured_column].to_numpy(dtype=float))
        shown = np.isfinite(measured) & (measured > 0)
        axes.plot(measured[shown], positions[shown], "o", color="#4c72b0", markersize=7, label="measured")
        values = [measured[shown]]
        if expected_column in rows:
            expected = np.abs(rows[expected_column].to_numpy(dtype=float))
            known = np.isfinite(expected) & (expected > 0)
            axes.plot(expected[known], positions[known], "o", markerfacecolor="none", markeredgecolor="black",
                      markersize=10, label="leading-order expectation", zorder=1.5)  # beneath the measured dots
            values.append(expected[known])
        for position in positions[~shown]:
            axes.text(0.01, position, "no finite value", transform=axes.get_yaxis_transform(), va="center",
                      fontsize=8)
        set_log_scales(axes, y=False)
        finite = np.concatenate(values)
        if finite.size:
            centre = np.sqrt(finite.min() * finite.max())
            half_span = max(10.0, np.sqrt(finite.max() / finite.min()) * 3.0)
            axes.set_xlim(centre / half_span, centre * half_span)
        axes.set_xlabel(label)
        axes.grid(True, axis="x", alpha=0.3)
    figure.legend(handles=panels[0].get_lines(), loc="outside lower center", ncols=2, fontsize=9)
    panels[0].set_yticks(positions, labels, fontsize=9)
    panels[0].set_ylim(len(rows) - 0.5, -0.5)
    figure.suptitle("Model adequacy: what each simpler model gets wrong, per scene")
    return figure
