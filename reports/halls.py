"""The report's table "against the measurement": real halls' measured precession rates (bench/scenes/
real_halls.toml, ``[measurement.NAME]`` tables) beside what the suite predicts for them, from the runs of the
``halls`` matrix.

Per measured hall, in degrees per hour clockwise seen from above (the sources' convention; the suite's signed
rate is counter-clockwise positive, so each is minus the stored ``precession_rate_rad_s``):

* the measured rate, its range and where the range comes from (``RANGE_KINDS``: an uncertainty or spread the source
  publishes, one computed here from the readings it publishes, or this suite's reading of a record stating none);
* the ideal model's prediction: the rate of the hall's ideal scene, from its most accurate ok run (smallest
  ``precession_rate_ref_error_rad_s``: the closest to the real128 reference) over the scene's duration;
* the prediction with the effect the scene needs, measured the same way on the effects scene: over a scene of
  minutes the support barely shows (it acts through the ellipticity it builds, at the second order in δ/a);
* the long-time mean with the effect, from the closed form (``models.analytic.anisotropic_precession_rate_rad_s``:
  −√(a² + δ²) while the plane turns), which is what a measurement over days sees;
* whether the ideal prediction and the long-time mean lie inside the measured range.

Then, when the runs hold a scene whose model conserves no energy, "who leads when the forces are not
conservative" (``bench.verdicts.nonconservative``): the leader and the cheapest symplectic method per scene and
target, the loss of the symplectic methods' advantage, and Gauss-Legendre's energy error against its energy-balance
residual.
"""

from __future__ import annotations

import math
import tomllib
from typing import Any

import pandas as pd

from foucault_bench.bench.problems.scenes import SCENE_DIRECTORY, SCENES
from foucault_bench.bench.verdicts import nonconservative
from foucault_bench.integrators import STATUS_OK
from foucault_bench.models.analytic import anisotropic_precession_rate_rad_s
from foucault_bench.reports.document import Heading, Paragraph

DEG_H_PER_RAD_S = 180.0 / math.pi * 3600.0
HALLS_FILE = SCENE_DIRECTORY / "real_halls.toml"
RANGE_KINDS = ("published standard deviation", "published spread", "standard deviation of the published readings",
               "a reading, no uncertainty published")
"""Where a measurement's range comes from (its ``range_kind``): the first two are the source's own, the third is
computed here from the readings the source publishes, the last is this suite's reading of a record."""


def measurements() -> dict[str, dict[str, Any]]:
    """The ``[measurement.NAME]`` tables of bench/scenes/real_halls.toml."""
    with open(HALLS_FILE, "rb") as handle:
        return tomllib.load(handle).get("measurement", {})


def _best_clockwise_deg_h(runs: pd.DataFrame, scene: str) -> float:
    """−rate (°/h) of the scene's ok run closest to the reference; NaN without one."""
    rows = runs[(runs["scene"] == scene) & (runs["status"] == STATUS_OK)]
    rows = rows[rows["precession_rate_ref_error_rad_s"].notna()]
    if rows.empty:
        return math.nan
    best = rows.loc[rows["precession_rate_ref_error_rad_s"].idxmin()]
    return -float(best["precession_rate_rad_s"]) * DEG_H_PER_RAD_S


def against_measurement(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per measured hall whose scenes have runs (columns in the module docstring's order)."""
    rows = []
    for hall, measured in measurements().items():
        ideal = _best_clockwise_deg_h(runs, measured["scene"])
        effects = _best_clockwise_deg_h(runs, measured["effects_scene"])
        if math.isnan(ideal) and math.isnan(effects):
            continue
        long_time = -anisotropic_precession_rate_rad_s(SCENES[measured["effects_scene"]].params) * DEG_H_PER_RAD_S
        low, high = measured["low_deg_h"], measured["high_deg_h"]
        rows.append({
            "hall": hall,
            "measured_deg_h": measured["measured_deg_h"],
            "measured_range_deg_h": f"{low:g} to {high:g}",
            "range_kind": measured["range_kind"],
            "ideal_deg_h": ideal,
            "with_effect_deg_h": effects,
            "with_effect_long_time_deg_h": long_time,
            "ideal_inside": bool(low <= ideal <= high),
            "long_time_inside": bool(low <= long_time <= high),
            "effect": SCENES[measured["effects_scene"]].assumptions,
            "source": measured["source"],
        })
    return pd.DataFrame(rows)


def closing_note(table: pd.DataFrame) -> str:
    """Where each prediction falls against the measurement, and why, one sentence per hall."""
    sentences = []
    for row in table.itertuples():
        ideal_place = "inside" if row.ideal_inside else "outside"
        long_place = "inside" if row.long_time_inside else "outside"
        sentences.append(
            f"{row.hall}: the ideal prediction {row.ideal_deg_h:.2f}°/h lies {ideal_place} the measured "
            f"{row.measured_range_deg_h}°/h (mean {row.measured_deg_h:g}; the range: {row.range_kind}); with the "
            f"support anisotropy the "
            f"long-time mean {row.with_effect_long_time_deg_h:.2f}°/h lies {long_place} it ({row.effect})")
    return ". ".join(sentences) + "." if sentences else ""


def add_section(builder: Any, runs: pd.DataFrame) -> None:
    """The sections "Against the measurement" and "When the forces are not conservative" of the report (each
    only when its rows exist)."""
    _add_measurement(builder, runs)
    _add_nonconservative(builder, runs)


def _add_measurement(builder: Any, runs: pd.DataFrame) -> None:
    table = against_measurement(runs)
    if table.empty:
        return
    builder.add(Heading("Against the measurement"), Paragraph(
        "Real halls with published measured precession rates (bench/scenes/real_halls.toml), in °/h clockwise "
        "seen from above: the measurement, its range and where that range comes from (published by the source, "
        "computed here from the readings it publishes, or read here from a record that states none), the ideal "
        "model, the model with the effect the scene needs over the scene, and its long-time mean from the closed "
        "form (models/README.md \"Anisotropic support\")."))
    builder.table(table, "against_measurement", "Against the measurement")
    builder.add(Paragraph(closing_note(table)))


def _add_nonconservative(builder: Any, runs: pd.DataFrame) -> None:
    table = nonconservative.leaders(runs)
    if table.empty or table["conservative"].all():
        return
    loss = nonconservative.symplectic_loss(table)
    builder.add(Heading("When the forces are not conservative"), Paragraph(
        "With drag or a drive the flow is not Hamiltonian and a symplectic method keeps no long-time advantage "
        "(bench/verdicts/nonconservative.py). Per scene and reference-error target: the cheapest run meeting it "
        "and the cheapest run of a symplectic integrator, with its cost over the leader's; then the median of "
        "that ratio on each kind of scene, and Gauss-Legendre's energy error (conservative scenes) against its "
        "energy-balance residual (the others) per step."))
    builder.table(table, "nonconservative_leaders", "Leaders and the cheapest symplectic run, per scene and target")
    builder.table(loss, "symplectic_loss", "The symplectic methods' cost over the leader's, by kind of scene")
    builder.table(nonconservative.conservation(runs), "gauss_legendre_conservation",
                  "Gauss-Legendre: energy error against energy-balance residual")
    builder.add(Paragraph(nonconservative.summary(table, loss)))
