"""The report's section "Ensembles": per ensemble, each verdict against the swept parameter, one line per
integrator and setting, and the work-precision of the worst member and of the median member.

Only draws: the member rows, the summary and the worst and median members come from
``bench.ensembles.summary``. The charts are matplotlib figures, shown on the page converted to plotly
(``reports.plotly_conversion.from_matplotlib``, through the builder's ``curves``) and saved as PNG + SVG for a static
report. The swept parameter is the ensemble's first swept field (a member's other fields, when it sweeps
several, are in its name in the summary table).
"""

from __future__ import annotations

import json
from typing import Any

import pandas as pd
from matplotlib.figure import Figure

from foucault_bench.bench.ensembles.summary import (
    ensemble_summary, median_rows, member_rows, swept_values, worst_rows,
)
from foucault_bench.reports import chart_style
from foucault_bench.reports.builder import file_stem
from foucault_bench.reports.document import Heading, Paragraph

ENSEMBLE_VERDICTS = ("reference_error", "precession_rate_ref_error_earth", "energy_max_rel_error")
"""The verdicts drawn against the swept parameter."""
WORK_PRECISION_VERDICT = "reference_error"
"""The error of the worst-member and median-member work-precision charts."""
VERDICT_TITLES = {"reference_error": "reference error", "precession_rate_ref_error_earth":
                  "precession-rate error (÷ Ω_E)", "energy_max_rel_error": "energy error"}


def first_field(members: pd.DataFrame) -> str:
    """The ensemble's first swept field (``ensemble_member`` keeps the ensemble's order)."""
    return next(iter(json.loads(members["ensemble_member"].iloc[0])))


def _line_label(integrator: str, setting: str) -> str:
    return f"{integrator} {setting}"


def verdict_against_parameter(members: pd.DataFrame, verdict: str) -> Figure:
    """``verdict`` of every ok member row against the swept parameter, one line per integrator and setting
    (members in parameter order; values below ``chart_style.LOG_FLOOR`` drawn at it)."""
    field = first_field(members)
    figure = Figure(figsize=(7.0, 4.2))
    axes = figure.subplots()
    table = swept_values(members)
    table = table[table["status"] == "ok"]
    for (integrator, setting), group in table.groupby(["integrator", "ensemble_setting"], sort=True):
        group = group.sort_values(field, kind="stable")
        values = group[verdict].astype(float).clip(lower=chart_style.LOG_FLOOR)
        axes.plot(group[field].astype(float), values, marker="o", markersize=3,
                  color=chart_style.family_colour(str(group["family"].iloc[0])), label=_line_label(integrator, setting))
    axes.set_yscale("log")
    axes.set_xlabel(field)
    axes.set_ylabel(VERDICT_TITLES[verdict])
    axes.set_title(f"{members['ensemble'].iloc[0]}: {VERDICT_TITLES[verdict]} against {field}")
    axes.legend(fontsize=6, ncol=2)
    return figure


def work_precision_of(picked: dict[str, pd.DataFrame], verdict: str) -> Figure:
    """One panel per entry of ``picked`` (``worst member``, ``median member``: a row per integrator and
    setting): its error against its CPU time, one line per integrator over its settings."""
    figure = Figure(figsize=(9.0, 4.0))
    panels = figure.subplots(1, len(picked), squeeze=False)[0]
    for axes, (title, rows) in zip(panels, picked.items(), strict=True):
        for integrator, group in rows.groupby("integrator", sort=True):
            group = group.sort_values("cpu_time_s", kind="stable")
            axes.plot(group["cpu_time_s"].astype(float), group[verdict].astype(float).clip(lower=chart_style.LOG_FLOOR),
                      marker="o", color=chart_style.family_colour(str(group["family"].iloc[0])), label=integrator)
        axes.set_xscale("log")
        axes.set_yscale("log")
        axes.set_xlabel("CPU time (s)")
        axes.set_ylabel(VERDICT_TITLES[verdict])
        axes.set_title(title)
        axes.legend(fontsize=7)
    return figure


def _cost_note(group: pd.DataFrame) -> str:
    """What the charts' CPU time is when the members were timed in batches (``batch_members``), else nothing."""
    if "batch_members" not in group.columns or group["batch_members"].isna().all():
        return ""
    return (" CPU time is a member's equal share of its batch's (the members of one integrator and setting run "
            "as one batch, bench/run/ensemble_jobs.py): what a member costs when the ensemble is run.")


def add_section(builder: Any, runs: pd.DataFrame) -> None:
    """The section "Ensembles" (nothing when no row is an ensemble member): per ensemble, its summary table,
    each verdict against the swept parameter, and the work-precision of its worst and median members; file
    names made from an ensemble's name by ``reports.builder.file_stem``."""
    members = member_rows(runs)
    if members.empty:
        return
    builder.add(Heading("Ensembles"), Paragraph(
        "An ensemble is a scene swept over its release or place; every member is a scene with its own reference. "
        "Per integrator and setting: the median, 90th percentile and worst error over the members, and which "
        "member is worst (bench/ensembles/summary.py)."))
    for ensemble, group in members.groupby("ensemble", sort=True):
        stem = file_stem(str(ensemble))
        builder.add(Heading(f"Ensemble {ensemble}", level=3))
        builder.table(ensemble_summary(group, WORK_PRECISION_VERDICT), f"ensemble_{stem}",
                      f"{ensemble}: {VERDICT_TITLES[WORK_PRECISION_VERDICT]} over the members")
        for verdict in ENSEMBLE_VERDICTS:
            if group[verdict].notna().any():
                builder.curves(f"ensemble_{stem}_{verdict}",
                               f"{ensemble}: {VERDICT_TITLES[verdict]} against {first_field(group)}, one line per "
                               "integrator and setting.", lambda table, verdict=verdict: verdict_against_parameter(
                                   table, verdict), group)
        picked = {"worst member": worst_rows(group, WORK_PRECISION_VERDICT),
                  "median member": median_rows(group, WORK_PRECISION_VERDICT)}
        if not picked["worst member"].empty:
            builder.curves(f"ensemble_{stem}_work_precision",
                           f"{ensemble}: work-precision of the worst member and of the median member of each "
                           f"integrator and setting ({VERDICT_TITLES[WORK_PRECISION_VERDICT]}).{_cost_note(group)}",
                           lambda _table, picked=picked: work_precision_of(picked, WORK_PRECISION_VERDICT), group)

