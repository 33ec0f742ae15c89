"""The history page: each verdict and the cost of every run against the revision, and the table of changes.

Drawn from a ``bench.history.load.History`` (computing is done there): one interactive chart per scene and
column (``HISTORY_COLUMNS``), a line per integrator and setting over the revisions in order, and the changes
between consecutive revisions. The page embeds each chart's data as JSON and loads plotly.js from a file beside
it, so it works offline. Everything users typed (scene and integrator names) is escaped.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import pandas as pd

from foucault_bench.bench.history.changes import changes_frame
from foucault_bench.bench.history.load import History

HISTORY_COLUMNS: tuple[str, ...] = ("reference_error", "precession_rate_ref_error_earth", "energy_max_rel_error",
                                    "cpu_time_s")
"""The columns drawn against the revision (log scale), one chart per scene each."""
PLOTLY_FILE = "plotly.min.js"


def history_figures(history: History) -> list[dict]:
    """One plotly figure (as a plain dict) per scene and column that has a finite positive value: x the revision
    labels in order, one trace per integrator and setting, NaN where that revision has no such value."""
    labels = [revision.label for revision in history.revisions]
    figures = []
    rows = history.rows
    for scene in sorted(rows["scene_label"].unique()):
        scene_rows = rows[rows["scene_label"] == scene]
        for column in HISTORY_COLUMNS:
            traces = []
            for (integrator, setting), runs in scene_rows.groupby(["integrator", "setting"], sort=True):
                values = dict(zip(runs["revision"], pd.to_numeric(runs[column], errors="coerce"), strict=True))
                y = [float(values[label]) if label in values and pd.notna(values[label]) and values[label] > 0
                     else None for label in labels]
                if any(value is not None for value in y):
                    traces.append({"type": "scatter", "mode": "lines+markers", "name": f"{integrator} {setting}",
                                   "x": labels, "y": y})
            if traces:
                figures.append({"scene": scene, "column": column, "data": traces,
                                "layout": {"title": {"text": f"{scene}: {column} by revision"},
                                           "xaxis": {"type": "category", "title": {"text": "revision"}},
                                           "yaxis": {"type": "log", "title": {"text": column}},
                                           "height": 420}})
    return figures


def _changes_table(history: History) -> str:
    frame = changes_frame(history.changes)
    if frame.empty:
        return "<p>No run changed between consecutive revisions.</p>"
    header = "".join(f"<th>{html.escape(str(column))}</th>" for column in frame.columns)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(value))}</td>" for value in row) + "</tr>"
                   for row in frame.itertuples(index=False))
    return f'<table id="changes"><thead><tr>{header}</tr></thead><tbody>{body}</tbody></table>'


def history_page(history: History) -> str:
    """The page's HTML (plotly.js from ``PLOTLY_FILE`` beside it)."""
    revisions = "".join(f"<li>{html.escape(revision.label)}: {len(revision.matrix_ids)} matrix run(s), first "
                        f"{html.escape(revision.started_utc)}</li>" for revision in history.revisions)
    charts = []
    for number, figure in enumerate(history_figures(history)):
        payload = json.dumps({"data": figure["data"], "layout": figure["layout"]}).replace("</", "<\\/")
        charts.append(f'<div id="chart-{number}" class="chart" data-scene="{html.escape(figure["scene"])}" '
                      f'data-column="{figure["column"]}"></div>'
                      f'<script type="application/json" id="chart-{number}-data">{payload}</script>')
    return (
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>foucault-bench history</title>"
        f'<script src="{PLOTLY_FILE}"></script></head><body>'
        "<h1>Accuracy and cost by revision</h1>"
        f"<p>{len(history.revisions)} revisions, ordered by {html.escape(history.ordered_by)}; "
        f"{len(history.changes)} change(s) between consecutive revisions.</p><ol>{revisions}</ol>"
        f"<h2>Changes</h2>{_changes_table(history)}<h2>Charts</h2>{''.join(charts)}"
        "<script>for (const node of document.querySelectorAll('.chart')) {"
        "const figure = JSON.parse(document.getElementById(node.id + '-data').textContent);"
        "Plotly.newPlot(node, figure.data, figure.layout);}</script></body></html>"
    )


def write_history(history: History, folder: Path) -> None:
    """Write ``history.html``, ``plotly.min.js``, ``changes.csv`` and ``history.csv`` into ``folder``."""
    from plotly.offline import get_plotlyjs

    (folder / "history.html").write_text(history_page(history), encoding="utf-8")
    (folder / PLOTLY_FILE).write_text(get_plotlyjs(), encoding="utf-8")
    changes_frame(history.changes).to_csv(folder / "changes.csv", index=False)
    keep = ["revision_index", "revision", "matrix_id", "scene_label", "integrator", "setting", "status",
            *HISTORY_COLUMNS]
    history.rows[[column for column in keep if column in history.rows.columns]].to_csv(folder / "history.csv",
                                                                                        index=False)
