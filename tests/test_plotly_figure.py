"""The report's charts, built as plain plotly data (``reports.plotly_figure``), are what plotly's validating
objects make of them: plotly accepts every property of each chart kind (work-precision, convergence, tolerance,
a converted matplotlib chart) and writes the same JSON for it as ``Plot.to_json``."""

from __future__ import annotations

import json
from pathlib import Path

import plotly.graph_objects as go


def test_charts_are_valid_plotly_and_write_the_same_json(fixture_database: Path) -> None:
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.verdicts.pareto import pareto_front
    from foucault_bench.reports import interactive, study_charts
    from foucault_bench.reports.plotly_conversion import from_matplotlib

    with ResultsStore(fixture_database, create=False) as store:
        runs, adequacy = store.frame(), store.adequacy()
    scene = runs[runs["scene"] == "pantheon"]
    plots = [interactive.work_precision(scene, "reference_error", pareto_front(scene, "reference_error")),
             interactive.convergence(scene[scene["tol"].isna()], {"rk4": 4.0}),
             interactive.tolerance(scene), from_matplotlib(study_charts.adequacy(adequacy))]
    for plot in plots:
        validated = go.Figure(plot.figure())  # raises on a property plotly does not know or a bad value
        assert json.loads(plot.to_json()) == json.loads(validated.to_json())
        assert interactive.drawn_points(plot) > 0
