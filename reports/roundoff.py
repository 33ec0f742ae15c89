"""The chart of the long-time round-off study (``bench.studies.long_time_roundoff``): the drift of each symmetric
scheme's invariant quadratic form against the number of steps, beside Brouwer's law ε√n."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from foucault_bench.reports.chart_style import integrator_style, set_log_scales

BROUWER_LABEL = "Brouwer's law ε√n"


def roundoff_growth(table: pd.DataFrame) -> Figure:
    """|ΔQ|/Q₀ (median over the releases of the RMS over each decade's window) against steps on log-log axes,
    one line per integrator with the releases' range as error bars, its fitted exponent in the legend, and the
    reference line ε√n."""
    figure = Figure(figsize=(10, 5.2), layout="constrained")
    axes = figure.subplots()
    for name, rows in table.groupby("integrator", sort=False):
        style = integrator_style(str(name), str(rows["family"].iloc[0]))
        steps = rows["steps"].to_numpy(dtype=float)
        drift = rows["drift_rms"].to_numpy(dtype=float)
        spread = np.vstack([drift - rows["drift_min"].to_numpy(dtype=float),
                            rows["drift_max"].to_numpy(dtype=float) - drift])
        axes.errorbar(steps, drift, yerr=spread, color=style["color"], linestyle=style["linestyle"], marker="o",
                      capsize=3, label=f"{name} (exponent {rows['exponent'].iloc[0]:.2f})")
    steps = np.sort(table["steps"].unique().astype(float))
    axes.plot(steps, np.finfo(np.float64).eps * np.sqrt(steps), color="grey", linestyle="--", label=BROUWER_LABEL)
    set_log_scales(axes)
    axes.set_xlabel("steps n")
    axes.set_ylabel("|Q(yₙ) − Q(y₀)| / Q(y₀)")
    axes.grid(True, which="major", alpha=0.3)
    axes.set_title(f"Round-off drift of the conserved quadratic form, linear model, kh = {table['kh'].iloc[0]:g}")
    axes.legend(fontsize=9)
    return figure
