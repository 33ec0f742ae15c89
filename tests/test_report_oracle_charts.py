"""Oracle tests of the report's charts: every chart of a report built from the fixture database
(``report_fixture``) is read back from index.html (the plotly JSON it embeds, binary arrays decoded) and compared
with that scene's rows, recomputed here from the database with plain sqlite3 and pandas, independently of the
code that drew the chart: titles name the right scene and verdict, each integrator's trace holds exactly its
runs' (cost, error) pairs, diverged and failed runs are all drawn above the data, the Pareto trace is the
brute-force non-dominated set, captions count what is drawn, PNGs of different data differ; and every element of
a static matplotlib chart (lines, reference lines, markers, spans, error bars, tick labels, panel titles) has its
counterpart in the interactive version (``reports.plotly_conversion.from_matplotlib``)."""

from __future__ import annotations

import base64
import hashlib
import json
import math
import re
import sqlite3
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from report_fixture import INLINE_SCENE, report_html

VERDICT_WORDS = {"reference_error": "reference error", "energy_max_rel_error": "energy error",
                 "energy_drift_per_s": "energy drift", "precession_rate_ref_error": "precession-rate error",
                 "analytic_gap_exact": "analytic gap"}
"""The verdicts the report draws against cost, and the words its chart titles name them by."""
ENERGY_VERDICTS = ("energy_max_rel_error", "energy_drift_per_s")
RELATIVE_TOLERANCE = 1e-12
"""Numbers go through JSON as doubles (plotly's binary arrays: the same bits); 1e-12 allows a decimal round trip."""


# --------------------------------------------------------------------------------------------------------------
# reading the page
# --------------------------------------------------------------------------------------------------------------
def decode(value: object) -> np.ndarray:
    """A plotly data array as floats: a list (None → NaN) or plotly's binary encoding
    ``{"dtype": ..., "bdata": base64, "shape": "r, c"}``."""
    if isinstance(value, dict) and "bdata" in value:
        array = np.frombuffer(base64.b64decode(value["bdata"]), dtype=np.dtype(value["dtype"])).astype(float)
        if "shape" in value:
            array = array.reshape([int(part) for part in str(value["shape"]).split(",")])
        return array
    if value is None:
        return np.array([], dtype=float)
    return np.array([math.nan if item is None else item for item in value], dtype=float)


@dataclass
class Chart:
    stem: str
    caption: str
    figure: dict
    chart_id: str = ""

    @property
    def title(self) -> str:
        title = self.figure["layout"].get("title", {})
        return title.get("text", "") if isinstance(title, dict) else str(title)

    def traces(self) -> list[dict]:
        """Data traces (without the legend's family toggles)."""
        return [trace for trace in self.figure["data"] if trace.get("meta") != "family-toggle"]


def page_charts(folder: Path) -> dict[str, Chart]:
    """Every chart of the report's pages (``report_fixture.report_html``) by its static file's stem
    (``figures/NAME``)."""
    html = report_html(folder)
    found = {}
    for stem, block in re.findall(r"<figure(?: id='[^']+' data-stem='([^']+)')?>(.*?)</figure>", html, re.S):
        data = re.search(r"var figure = (.*?); Plotly\.newPlot", block, re.S)
        chart_id = re.search(r"<div class='chart' id='([^']+)'", block)
        assert stem and data is not None and chart_id is not None, f"{block[:200]}: not interactive"
        caption = re.search(r"<figcaption>(.*?)(?: \(static:.*)?</figcaption>", block, re.S).group(1)
        found[stem] = Chart(stem, caption, json.loads(data.group(1)), chart_id.group(1))
    return found


def integrator_of(trace: dict) -> str:
    """The integrator a trace is named after ("rk4 (1 diverged), fitted order 4.00" → rk4)."""
    return re.split(r"[ ,]", trace["name"], maxsplit=1)[0]


def points(trace: dict) -> set[tuple[float, float]]:
    x, y = decode(trace.get("x")), decode(trace.get("y"))
    return {(float(a), float(b)) for a, b in zip(x, y, strict=True)}


def same_points(drawn: set[tuple[float, float]], expected: set[tuple[float, float]]) -> bool:
    if len(drawn) != len(expected):
        return False
    return all(any(math.isclose(a, c, rel_tol=RELATIVE_TOLERANCE) and math.isclose(b, d, rel_tol=RELATIVE_TOLERANCE)
                   for c, d in expected) for a, b in drawn)


# --------------------------------------------------------------------------------------------------------------
# the database, read independently of the report code
# --------------------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def rows(fixture_database: Path) -> pd.DataFrame:
    with sqlite3.connect(fixture_database) as connection:
        latest = connection.execute("SELECT matrix_id FROM matrix_runs ORDER BY started_utc DESC LIMIT 1").fetchone()[0]
        return pd.read_sql_query("SELECT * FROM runs WHERE matrix_id = ?", connection, params=(latest,))


@pytest.fixture(scope="module")
def adequacy_rows(fixture_database: Path) -> pd.DataFrame:
    with sqlite3.connect(fixture_database) as connection:
        return pd.read_sql_query("SELECT * FROM adequacy", connection)


@pytest.fixture(scope="module")
def charts(fixture_report: Path) -> dict[str, Chart]:
    return page_charts(fixture_report)


def stem_part(scene: str) -> str:
    """The file-name part of a scene name (the fixture's names are lower-case words: unchanged)."""
    assert re.fullmatch(r"[a-z0-9_]+", scene)
    return scene


def plottable(frame: pd.DataFrame, x: str, y: str) -> pd.DataFrame:
    """Ok runs with finite, positive x and |y|."""
    ok = frame[frame["status"] == "ok"]
    x_values, y_values = ok[x].astype(float), ok[y].astype(float).abs()
    return ok[np.isfinite(x_values) & (x_values > 0) & np.isfinite(y_values) & (y_values > 0)]


def pairs(frame: pd.DataFrame, x: str, y: str) -> set[tuple[float, float]]:
    return {(float(a), abs(float(b))) for a, b in zip(frame[x], frame[y], strict=True)}


def metric_applies(frame: pd.DataFrame, verdict: str) -> pd.Series:
    """Where an error metric measures the integrator: energy errors only for a model that conserves energy
    (the ``energy_conserved`` column), the analytic gap only for the linear model (whose exact solution it is)."""
    if verdict in ENERGY_VERDICTS:
        return frame["energy_conserved"] == 1
    if verdict == "analytic_gap_exact":
        return frame["model"] == "linear"
    return pd.Series(True, index=frame.index)


def brute_force_front(frame: pd.DataFrame, verdict: str, cost: str = "cpu_time_s") -> set[tuple[float, float]]:
    """The (cost, error) pairs no other usable run beats: cost ≤ and error ≤ with one of them strictly."""
    usable = frame[(frame["status"] == "ok") & metric_applies(frame, verdict)]
    usable = usable[np.isfinite(usable[cost].astype(float)) & (usable[cost] > 0)
                    & np.isfinite(usable[verdict].astype(float))]
    candidates = pairs(usable, cost, verdict)
    return {(c, e) for c, e in candidates
            if not any(c2 <= c and e2 <= e and (c2 < c or e2 < e) for c2, e2 in candidates)}


# --------------------------------------------------------------------------------------------------------------
# every chart is there, of the right scene
# --------------------------------------------------------------------------------------------------------------
def expected_stems(rows: pd.DataFrame) -> set[str]:
    stems = {"figures/model_adequacy"}
    for scene, scene_rows in rows.groupby("scene"):
        stems |= {f"figures/work_precision_{stem_part(scene)}_{verdict}" for verdict in VERDICT_WORDS}
        if scene_rows["tol"].isna().any():
            stems.add(f"figures/convergence_{stem_part(scene)}")
        if scene_rows["tol"].notna().any():
            stems.add(f"figures/tolerance_{stem_part(scene)}")
    return stems


def test_every_chart_of_every_scene_is_on_the_page(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    assert set(charts) == expected_stems(rows)
    assert INLINE_SCENE in set(rows["scene"])


def test_work_precision_charts_show_their_scene_and_verdict(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    titles = set()
    for scene, scene_rows in rows.groupby("scene"):
        for verdict, words in VERDICT_WORDS.items():
            chart = charts[f"figures/work_precision_{stem_part(scene)}_{verdict}"]
            assert chart.title.startswith(f"{scene}: {words} against cost"), (chart.stem, chart.title)
            assert chart.caption.startswith(f"{scene}: {words} ("), (chart.stem, chart.caption)
            titles.add(chart.title)
            traces = chart.traces()
            drawn_integrators = {integrator_of(trace) for trace in traces
                                 if trace.get("mode") == "lines+markers"}
            assert drawn_integrators == set(plottable(scene_rows, "cpu_time_s", verdict)["integrator"]), chart.stem
            for integrator, runs in scene_rows.groupby("integrator"):
                lines = [trace for trace in traces if trace.get("mode") == "lines+markers"
                         and integrator_of(trace) == integrator]
                by_axis = {trace.get("xaxis", "x"): trace for trace in lines}
                for axis, cost in (("x", "cpu_time_s"), ("x2", "steps")):
                    expected = pairs(plottable(runs, cost, verdict), cost, verdict)
                    drawn = points(by_axis[axis]) if axis in by_axis else set()
                    assert same_points(drawn, expected), (chart.stem, integrator, cost, drawn, expected)
    assert len(titles) == len(rows["scene"].unique()) * len(VERDICT_WORDS)


def test_the_time_axis_bars_are_the_stored_precision(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    """On every work-precision chart's time axis, each run's bar reaches cpu_time_s · (1 ± cpu_time_ci95_rel)
    (the stored 95 % confidence interval of the median; the left half clipped at 0.9 × the cost on the log axis),
    and a run without a stated precision has no bar."""
    checked = {"with": 0, "without": 0}
    for scene, scene_rows in rows.groupby("scene"):
        for verdict in VERDICT_WORDS:
            chart = charts[f"figures/work_precision_{stem_part(scene)}_{verdict}"]
            for trace in chart.traces():
                if trace.get("mode") != "lines+markers" or trace.get("xaxis", "x") != "x":
                    continue
                runs = plottable(scene_rows[scene_rows["integrator"] == integrator_of(trace)], "cpu_time_s", verdict)
                bars = trace.get("error_x") or {}
                plus = decode(bars.get("array")) if bars else np.full(len(decode(trace["x"])), np.nan)
                for x, half in zip(decode(trace["x"]), plus, strict=True):
                    run = runs[np.isclose(runs["cpu_time_s"].astype(float), x, rtol=RELATIVE_TOLERANCE)].iloc[0]
                    precision = run["cpu_time_ci95_rel"]
                    if pd.isna(precision):
                        assert np.isnan(half), (chart.stem, x)
                        checked["without"] += 1
                    else:
                        assert math.isclose(half, precision * run["cpu_time_s"], rel_tol=1e-9), (chart.stem, x)
                        checked["with"] += 1
    assert checked["with"] and checked["without"]  # the fixture has both kinds: both checks ran


def test_the_pareto_trace_is_the_non_dominated_set(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    for scene, scene_rows in rows.groupby("scene"):
        for verdict in VERDICT_WORDS:
            chart = charts[f"figures/work_precision_{stem_part(scene)}_{verdict}"]
            front = brute_force_front(scene_rows, verdict)
            drawn = [trace for trace in chart.traces() if trace["name"].startswith("Pareto front")]
            if front:
                assert len(drawn) == 1 and drawn[0].get("xaxis", "x") == "x", chart.stem
                assert same_points(points(drawn[0]), front), (chart.stem, points(drawn[0]), front)
                assert f"Pareto front ({len(front)} runs)" in chart.caption, chart.caption
            else:  # nothing to draw: the caption says why instead of announcing "0 runs"
                assert not drawn, chart.stem
                assert "0 runs" not in chart.caption and "no Pareto front" in chart.caption, chart.caption
                model = scene_rows["model"].iloc[0]
                reason = "conserves no energy" if verdict in ENERGY_VERDICTS else f"the {model} model"
                assert reason in chart.caption, chart.caption


def test_diverged_and_failed_runs_are_drawn_above_the_data(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    """Every run that diverged or failed is a marker of its integrator's "not ok" trace on both cost panels:
    at its cost when it has one, else left of every other point, and above every plotted value; every ok run
    without a value is a marker of its integrator's "no value" trace below every plotted value."""
    checked = no_values = 0
    for scene, scene_rows in rows.groupby("scene"):
        for verdict in VERDICT_WORDS:
            chart = charts[f"figures/work_precision_{stem_part(scene)}_{verdict}"]
            traces = chart.traces()
            for axis, cost in (("x", "cpu_time_s"), ("x2", "steps")):
                on_axis = [trace for trace in traces if trace.get("xaxis", "x") == axis]
                data_x = np.concatenate([decode(t["x"]) for t in on_axis if t.get("mode") == "lines+markers"])
                data_y = np.concatenate([decode(t["y"]) for t in on_axis if t.get("mode") == "lines+markers"])
                for integrator, runs in scene_rows.groupby("integrator"):
                    not_ok = runs[runs["status"] != "ok"]
                    drawn = [t for t in on_axis if t["name"] == f"{integrator} not ok"]
                    if not_ok.empty:
                        assert not drawn, (chart.stem, integrator)
                        continue
                    assert len(drawn) == 1, (chart.stem, integrator, axis)
                    x, y = decode(drawn[0]["x"]), decode(drawn[0]["y"])
                    assert len(x) == len(not_ok), (chart.stem, integrator, axis, x)
                    known = not_ok[cost].astype(float)
                    known = known[np.isfinite(known) & (known > 0)].to_numpy()
                    assert np.allclose(np.sort(x[np.isin(x, known)]), np.sort(known), rtol=RELATIVE_TOLERANCE), (
                        chart.stem, integrator, axis)
                    assert np.all(x[~np.isin(x, known)] < data_x.min()), (chart.stem, integrator, axis)
                    assert np.all(y > data_y.max()), (chart.stem, integrator, axis)
                    checked += len(not_ok)
                for integrator, runs in scene_rows[scene_rows["status"] == "ok"].groupby("integrator"):
                    values = runs[verdict].astype(float).abs()
                    no_value = runs[~(np.isfinite(values) & (values > 0))]
                    drawn = [t for t in on_axis if t["name"] == f"{integrator} no value"]
                    assert len(drawn) == (0 if no_value.empty else 1), (chart.stem, integrator, axis)
                    if drawn:
                        assert sorted(decode(drawn[0]["x"])) == pytest.approx(sorted(no_value[cost].astype(float)))
                        assert np.all(decode(drawn[0]["y"]) < data_y.min()), (chart.stem, integrator)
                        no_values += len(no_value)
    assert checked == 2 * len(VERDICT_WORDS) * int((rows["status"] != "ok").sum())
    assert no_values > 0  # the fixture has an ok run without a value: the check above ran


def assert_sweep_lines(traces: list[dict], sweep_rows: pd.DataFrame, setting: str, scene: str) -> None:
    """Each integrator's line of a sweep chart (reference error against ``setting``, kh or tol) holds exactly its
    plottable runs (an integrator with none may keep an empty line, its legend entry: every run of explicit Euler
    diverges on the default matrix's airy_3m), and its runs that are not ok are drawn at their settings in its
    "not ok" trace."""
    for integrator, runs in sweep_rows.groupby("integrator"):
        lines = [t for t in traces if t.get("mode") == "lines+markers" and integrator_of(t) == integrator]
        expected = pairs(plottable(runs, setting, "reference_error"), setting, "reference_error")
        assert len(lines) == 1 if expected else len(lines) <= 1, (scene, integrator, len(lines))
        assert same_points(points(lines[0]) if lines else set(), expected), (scene, integrator)
        not_ok = runs[runs["status"] != "ok"]
        drawn = [t for t in traces if t["name"] == f"{integrator} not ok"]
        assert sorted(decode(drawn[0]["x"]) if drawn else []) == pytest.approx(sorted(not_ok[setting])), integrator


def test_convergence_charts_show_each_scenes_fixed_step_runs(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    for scene, scene_rows in rows.groupby("scene"):
        chart = charts[f"figures/convergence_{stem_part(scene)}"]
        assert chart.title.startswith(f"{scene}: convergence"), chart.title
        fixed = scene_rows[scene_rows["tol"].isna()]
        traces = chart.traces()
        assert_sweep_lines(traces, fixed, "kh", scene)
        assert {t["name"] for t in traces if t["name"].startswith("slope ")} == {
            f"slope {order}" for order in fixed["declared_order"].dropna().astype(int).unique()}
        assert not set(scene_rows.loc[scene_rows["tol"].notna(), "integrator"]) & {integrator_of(t) for t in traces}


def test_tolerance_charts_show_each_scenes_adaptive_runs(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    for scene, scene_rows in rows.groupby("scene"):
        chart = charts[f"figures/tolerance_{stem_part(scene)}"]
        assert chart.title.startswith(f"{scene}: achieved error"), chart.title
        adaptive = scene_rows[scene_rows["tol"].notna()]
        traces = chart.traces()
        assert_sweep_lines(traces, adaptive, "tol", scene)
        diagonal = [t for t in traces if t["name"] == "error = tolerance"]
        assert len(diagonal) == 1
        assert sorted(points(diagonal[0])) == [(adaptive["tol"].min(),) * 2, (adaptive["tol"].max(),) * 2]


def test_pngs_of_different_data_differ(fixture_report: Path, rows: pd.DataFrame) -> None:
    digests = {hashlib.sha256(path.read_bytes()).hexdigest()
               for path in (fixture_report / "figures").glob("*.png")}
    assert len(digests) == len(expected_stems(rows))


def test_adequacy_chart_labels_rows_and_keeps_measured_dots_visible(charts: dict[str, Chart],
                                                                    adequacy_rows: pd.DataFrame) -> None:
    chart = charts["figures/model_adequacy"]
    layout = chart.figure["layout"]
    labels = [f"{r.scene}: {r.simpler_model} vs {r.model}" for r in adequacy_rows.itertuples()]
    assert layout["yaxis"]["ticktext"] == labels
    assert list(decode(layout["yaxis"]["tickvals"])) == list(range(len(labels)))
    measured = [t for t in chart.traces() if t["name"] == "measured"]
    expected = [t for t in chart.traces() if t["name"].startswith("leading-order")]
    for trace, column in zip(measured, ("precession_rate_diff", "trajectory_gap"), strict=True):
        assert same_points(points(trace), {(abs(v), float(i)) for i, v in enumerate(adequacy_rows[column])})
    assert len(measured) == 2 and expected
    for trace in expected:  # hollow and drawn before (beneath) the measured dots of its panel
        assert trace["marker"]["symbol"].endswith("-open"), trace["marker"]
        panel = [t for t in chart.traces() if t.get("xaxis", "x") == trace.get("xaxis", "x")]
        assert panel.index(trace) < min(panel.index(t) for t in measured if t in panel)


# --------------------------------------------------------------------------------------------------------------
# every element of a static chart is in its interactive version
# --------------------------------------------------------------------------------------------------------------
MATPLOTLIB_SYMBOLS = {"o": "circle", "s": "square", "D": "diamond", "v": "triangle-down", "^": "triangle-up",
                      "X": "x", "P": "cross", "*": "star", "h": "hexagon", "<": "triangle-left",
                      ">": "triangle-right", "p": "pentagon"}


def _panels(figure) -> list:
    """The visible panels of a matplotlib figure, row by row (the order plotly numbers its subplots)."""
    panels = [axes for axes in figure.axes if axes.get_subplotspec() is not None and axes.get_visible()]
    return sorted(panels, key=lambda axes: (axes.get_subplotspec().rowspan.start, axes.get_subplotspec().colspan.start))


def _refs(index: int) -> tuple[str, str]:
    return ("x", "y") if index == 1 else (f"x{index}", f"y{index}")


def _close(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.all((np.isnan(a) & np.isnan(b)) | np.isclose(a, b, rtol=1e-9, atol=0)))


def assert_static_elements_are_interactive(static, plotly_figure: dict, name: str) -> None:
    """Each panel's lines (data, reference lines, markers on the axes' edges), error bars, shaded spans, hand-set
    ticks and labels, title and texts of the matplotlib figure ``static`` are in ``plotly_figure`` (its JSON)."""
    layout = plotly_figure["layout"]
    traces = plotly_figure["data"]
    shapes = layout.get("shapes", [])
    annotations = [annotation.get("text", "") for annotation in layout.get("annotations", [])]
    panels = _panels(static)
    rows = 1 + max(axes.get_subplotspec().rowspan.start for axes in panels)
    assert layout.get("height", 0) >= 250 * rows, (name, layout.get("height"), rows)
    for index, axes in enumerate(panels, start=1):
        x_ref, y_ref = _refs(index)
        here = [t for t in traces if t.get("xaxis", "x") == x_ref and t.get("yaxis", "y") == y_ref]
        caps = {id(cap) for container in axes.containers for cap in getattr(container, "lines", (None, ()))[1] or ()}
        for line in axes.get_lines():
            if id(line) in caps or not line.get_visible():
                continue
            x, y = np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)
            where = f"{name} panel {index} line {line.get_label()!r}"
            if line.get_transform() == axes.get_xaxis_transform() and list(y) == [0, 1]:  # axvline
                assert any(s.get("type") == "line" and s.get("xref") == x_ref and s["x0"] == s["x1"] == x[0]
                           for s in shapes), where
                continue
            if line.get_transform() == axes.get_yaxis_transform() and list(x) == [0, 1]:  # axhline
                assert any(s.get("type") == "line" and s.get("yref") == y_ref and s["y0"] == s["y1"] == y[0]
                           for s in shapes), where
                continue
            if line.get_transform() == axes.transData:
                found = [t for t in here if _close(decode(t["x"]), x) and _close(decode(t["y"]), y)]
            elif line.get_transform() == axes.get_xaxis_transform():  # x in data, y on an edge of the axes
                found = [t for t in here if _close(decode(t["x"]), x) and len(decode(t["y"])) == len(y)]
            else:  # axes coordinates (markers on an edge whose x is unknown)
                found = [t for t in here if len(decode(t["x"])) == len(x)]
            assert found, where
            marker = line.get_marker()
            if marker not in (None, "None", "", " "):
                symbol = MATPLOTLIB_SYMBOLS[marker] + ("-open" if str(line.get_markerfacecolor()).lower() == "none"
                                                       else "")
                assert any("markers" in t["mode"] and t["marker"]["symbol"] == symbol for t in found), (where, symbol)
            if line.get_linestyle() not in ("None", "", " "):
                assert any("lines" in t["mode"] for t in found), where
        for container in axes.containers:
            data_line, _, bars = container.lines
            for collection in bars:
                segments = np.array([np.asarray(s, dtype=float) for s in collection.get_segments()])
                vertical = np.allclose(segments[:, 0, 0], segments[:, -1, 0])
                key, column = ("error_y", 1) if vertical else ("error_x", 0)
                centre = np.asarray(data_line.get_ydata() if vertical else data_line.get_xdata(), dtype=float)
                plus = segments[:, :, column].max(axis=1) - centre
                assert any(key in t and _close(decode(t[key]["array"]), plus) for t in here), (name, index, key)
        for patch in axes.patches:  # shaded spans (axvspan)
            corners = (patch.get_transform() - axes.transData).transform(patch.get_path().vertices)
            low, high = corners[:, 0].min(), corners[:, 0].max()
            assert any(s.get("type") == "rect" and s.get("xref") == x_ref and math.isclose(s["x0"], low)
                       and math.isclose(s["x1"], high) for s in shapes), (name, index, low, high)
        for axis, key in ((axes.xaxis, "xaxis"), (axes.yaxis, "yaxis")):
            locator = axis.get_major_locator()
            if type(locator).__name__ == "FixedLocator":
                plotly_axis = layout[key + ("" if index == 1 else str(index))]
                positions = list(axis.get_majorticklocs())
                assert list(decode(plotly_axis["tickvals"])) == pytest.approx(positions), (name, index, key)
                labels = list(axis.get_major_formatter().format_ticks(positions))
                if any(labels):
                    assert plotly_axis["ticktext"] == labels, (name, index, key)
        if axes.get_title():
            assert axes.get_title() in annotations, (name, index)
        for text in axes.texts:
            if text.get_visible() and text.get_text().strip():
                assert text.get_text().strip() in annotations, (name, index, text.get_text())


def synthetic_study_tables() -> dict[str, pd.DataFrame]:
    """Small study tables with the columns the study charts read (``reports.study_charts``): a fixed-step integrator
    with a declared limit and diverged runs, one without a limit, error bars, an unknown value."""
    config = {"config_model": "linear", "config_length_m": 67.0, "config_latitude_deg": 48.8, "config_steps": 1000,
              "config_amplitude_m": 3.0, "config_duration_s": 3600.0}
    stability = pd.DataFrame([
        {"integrator": integrator, "family": family, "rotation": rotation, "kh": kh, "status": status,
         "energy_max_rel_error": error, "measured_limit_kh": measured, "stability_limit_kh": limit,
         "rate_ratio": 0.1 if rotation else 0.0, "growth_per_step": 1e-6 * kh, "growth_theory": theory * kh,
         **config}
        for integrator, family, limit, measured, theory in (("verlet", "verlet", 2.0, 2.0, math.nan),
                                                             ("explicit_euler", "euler", math.nan, math.nan, 1e-6),
                                                             ("rk4", "runge-kutta", 2.83, 2.8, math.nan))
        for rotation in (False, True)
        for kh, status, error in ((0.5, "ok", 1e-3), (1.5, "ok", 4e-2), (3.0, "diverged", math.nan))])
    precession = pd.DataFrame({"latitude_deg": [-60.0, 0.0, 30.0, 60.0], "textbook_rate_rad_s": [6e-5, 0, -3e-5, -6e-5],
                               "rate_rad_s": [6.1e-5, 1e-7, -2.9e-5, -6.2e-5],
                               "airy_rate_rad_s": [6.05e-5, 0, -3e-5, -6.05e-5],
                               "rate_stderr_rad_s": [1e-7, 2e-7, 1e-7, 3e-7], **config})
    azimuth = pd.DataFrame([{"latitude_deg": lat, "integrator": name, "family": family, "release_azimuth_deg": az,
                             "status": "ok", "error_earth": 1e-3 * (1 + az / 90) * (lat / 30), "kh": 0.1, **config}
                            for lat in (60.0, 30.0) for name, family in (("verlet", "verlet"), ("rk4", "runge-kutta"))
                            for az in (0.0, 45.0, 90.0)])
    energy = pd.DataFrame([{"integrator": name, "family": family, "status": status, "t_s": t, "setting": "kh=0.2",
                            "energy_rel_error": value, **config}
                           for name, family, status in (("verlet", "verlet", "ok"),
                                                        ("explicit_euler", "euler", "diverged"))
                           for t, value in ((10.0, 1e-4), (100.0, 2e-4 if name == "verlet" else 1e2),
                                            (1000.0, 1.5e-4 if name == "verlet" else math.nan))])
    return {"stability": stability, "precession": precession, "azimuth": azimuth, "energy": energy}


def test_study_charts_keep_every_element_in_their_interactive_version() -> None:
    from foucault_bench.reports import study_charts as static_charts
    from foucault_bench.reports.plotly_conversion import from_matplotlib

    tables = synthetic_study_tables()
    figures = {"stability": static_charts.stability(tables["stability"]),
               "rotation_growth": static_charts.rotation_growth(tables["stability"]),
               "precession_latitude": static_charts.precession_latitude(tables["precession"]),
               "release_azimuth": static_charts.release_azimuth(tables["azimuth"]),
               "long_time_energy": static_charts.long_time_energy(tables["energy"])}
    for name, figure in figures.items():
        assert_static_elements_are_interactive(figure, json.loads(from_matplotlib(figure).to_json()), name)
    stability = json.loads(from_matplotlib(figures["stability"]).to_json())
    assert sum(s.get("type") == "rect" for s in stability["layout"]["shapes"]) == 2  # verlet's and rk4's zones
    assert any(t["marker"]["symbol"] == "triangle-up" for t in stability["data"] if "markers" in t["mode"])


def test_adequacy_chart_keeps_every_element(charts: dict[str, Chart], adequacy_rows: pd.DataFrame) -> None:
    from foucault_bench.reports import study_charts as static_charts

    assert_static_elements_are_interactive(static_charts.adequacy(adequacy_rows),
                                           charts["figures/model_adequacy"].figure, "model_adequacy")


def _interval_set(trace: dict, key: str, axis: str) -> set[tuple[float, float]]:
    """(low, high) of each error bar of a trace along ``axis`` ("x" or "y"); a NaN length draws no bar."""
    centre = decode(trace[axis])
    plus, minus = decode(trace[key]["array"]), decode(trace[key].get("arrayminus", trace[key]["array"]))
    return {(round(float(c - m), 15), round(float(c + p), 15)) for c, p, m in zip(centre, plus, minus, strict=True)
            if math.isfinite(p) and math.isfinite(m)}


def assert_result_chart_elements_are_interactive(static, interactive: dict, name: str) -> None:
    """A chart of results rows (``reports.charts``): each data line of the static figure (integrator sweeps,
    Pareto staircase, reference slopes, diagonal) is a trace of the same points and marker on the same panel,
    each error bar spans the same interval, and each marker on an edge (▲ diverged, ✕ failed, ▽ no value) is
    a marker of the same symbol, at the same x where the static chart knows it. The setting written at the end of
    each static line is in the interactive version's hover text of that point."""
    traces = interactive["data"]
    for index, axes in enumerate(_panels(static), start=1):
        x_ref, _ = _refs(index)
        here = [t for t in traces if t.get("xaxis", "x") == x_ref and t.get("meta") != "family-toggle"]
        edge_counts: dict[str, int] = {}
        edge_x: dict[str, list[float]] = {}
        caps = {id(cap) for container in axes.containers for cap in container.lines[1]}  # ends of error bars
        for line in axes.get_lines():
            if id(line) in caps:
                continue
            x, y = np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)
            where = f"{name} panel {index} {line.get_label()!r}"
            if line.get_transform() == axes.transData:
                if not len(x):
                    continue
                expected = {(float(a), float(b)) for a, b in zip(x, y, strict=True)}
                found = [t for t in here if same_points(points(t), expected)]
                assert found, where
                if not str(line.get_label()).startswith("_") and line.get_marker() not in (None, "None", ""):
                    assert integrator_of(found[0]) == re.split(r"[ ,]", str(line.get_label()))[0], where
                    assert found[0]["marker"]["symbol"] == MATPLOTLIB_SYMBOLS[line.get_marker()], where
                continue
            symbol = MATPLOTLIB_SYMBOLS[line.get_marker()]
            edge_counts[symbol] = edge_counts.get(symbol, 0) + len(x)
            if line.get_transform() == axes.get_xaxis_transform():
                edge_x.setdefault(symbol, []).extend(x)
        drawn_counts: dict[str, int] = {}
        drawn_x: dict[str, list[float]] = {}
        for trace in here:
            if trace["name"].endswith((" not ok", " no value")):
                symbols = trace["marker"]["symbol"]
                symbols = symbols if isinstance(symbols, list) else [symbols] * len(decode(trace["x"]))
                for symbol, value in zip(symbols, decode(trace["x"]), strict=True):
                    drawn_counts[symbol] = drawn_counts.get(symbol, 0) + 1
                    drawn_x.setdefault(symbol, []).append(value)
        assert drawn_counts == edge_counts, (name, index, drawn_counts, edge_counts)
        for symbol, values in edge_x.items():
            assert all(any(math.isclose(v, w, rel_tol=RELATIVE_TOLERANCE) for w in drawn_x[symbol]) for v in values)
        static_bars = set()
        for collection in axes.collections:
            for segment in collection.get_segments():
                segment = np.asarray(segment, dtype=float)
                static_bars.add((round(float(segment[:, 0].min()), 15), round(float(segment[:, 0].max()), 15)))
        drawn_bars = set().union(*[_interval_set(t, "error_x", "x") for t in here if t.get("error_x")])
        assert len(drawn_bars) == len(static_bars) and all(
            any(math.isclose(a, c, rel_tol=1e-9) and math.isclose(b, d, rel_tol=1e-9) for c, d in drawn_bars)
            for a, b in static_bars), (name, index)
        hover = {str(cell) for t in here for row in (t.get("customdata") or []) for cell in row}
        for text in axes.texts:
            if text.get_text().startswith(("kh=", "tol=")):
                assert text.get_text() in hover, (name, index, text.get_text())


def test_result_charts_keep_every_static_element(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    from foucault_bench.bench.verdicts.pareto import pareto_front
    from foucault_bench.reports import charts as static_charts
    from foucault_bench.reports.tables import convergence_orders, orders_by_integrator

    orders = convergence_orders(rows)
    for scene, scene_rows in rows.groupby("scene"):
        for verdict in VERDICT_WORDS:
            figure = static_charts.work_precision_figure(scene_rows, verdict, pareto_front(scene_rows, verdict))
            stem = f"figures/work_precision_{stem_part(scene)}_{verdict}"
            assert_result_chart_elements_are_interactive(figure, charts[stem].figure, stem)
        figure = static_charts.convergence_figure(scene_rows, orders_by_integrator(orders, scene))
        assert_result_chart_elements_are_interactive(figure, charts[f"figures/convergence_{scene}"].figure, scene)
        figure = static_charts.tolerance_figure(scene_rows)
        assert_result_chart_elements_are_interactive(figure, charts[f"figures/tolerance_{scene}"].figure, scene)


def test_hover_texts_name_each_run_with_the_digits_the_tables_use(charts: dict[str, Chart], rows: pd.DataFrame) -> None:
    """Each point's hover text is its run's: the setting with 4 significant digits (kh=0.2712, as tables print
    it) and counts in full (3600 steps, not 3.6e+03)."""
    checked = 0
    for scene, scene_rows in rows.groupby("scene"):
        chart = charts[f"figures/work_precision_{stem_part(scene)}_reference_error"]
        for trace in chart.traces():
            if trace.get("mode") != "lines+markers" or trace.get("xaxis", "x") != "x":
                continue
            runs = plottable(scene_rows[scene_rows["integrator"] == integrator_of(trace)], "cpu_time_s",
                             "reference_error")
            for x, hover in zip(decode(trace["x"]), trace["customdata"], strict=True):
                run = runs[np.isclose(runs["cpu_time_s"], x, rtol=RELATIVE_TOLERANCE)].iloc[0]
                setting = f"tol={run['tol']:g}" if pd.notna(run["tol"]) else f"kh={run['kh']:.4g}"
                assert hover[0] == run["integrator"] and hover[2] == setting, (hover, setting)
                assert hover[6] == str(int(run["nfev"])) and hover[7] == str(int(run["steps"])), hover
                checked += 1
    assert checked == int(((rows["status"] == "ok") & rows["reference_error"].notna()).sum())


def test_the_overview_says_where_runs_without_a_value_are_drawn(fixture_report: Path) -> None:
    """The reading guide describes what ``test_diverged_and_failed_runs_are_drawn_above_the_data`` checks."""
    html = (fixture_report / "index.html").read_text(encoding="utf-8")
    guide = re.search(r"How to read the charts:(.*?)</p>", html, re.S).group(1)
    assert "drawn above the data at their cost, or at the left edge when the cost is unknown" in guide
    assert "drawn below the data (▽" in guide
