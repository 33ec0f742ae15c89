"""The interactive report in a real headless browser: index.html is opened from disk with no network, and every
plotly chart must have drawn its points (each chart's div says how many markers its data has,
``reports.interactive.drawn_points``; the browser's DOM must hold exactly that many marker paths) and its
lines and legend. On the report of the fixture database (``report_fixture``) the numbers the browser holds
after decoding each chart's data, read back from the page by a probe script, must equal that scene's rows in
the database (the oracles of ``test_report_oracle_charts``), and each trace must draw one marker per finite
point. Needs Debian's ``chromium`` (installed by .ci/run); skipped when it is absent outside CI."""

from __future__ import annotations

import json
import os
import re
import shutil
import sqlite3
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from foucault_bench.reports.build import ReportInputs, build_report
from foucault_bench.bench.studies import (
    LongTimeEnergyConfig,
    PrecessionLatitudeConfig,
    StabilitySweepConfig,
    long_time_energy,
    precession_vs_latitude,
    seed_series,
    stability_sweep,
)
import test_report_oracle_charts as oracle
from report_fixture import report_html, report_pages
from test_reports import adequacy_fixture, results_fixture

BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")
BROWSER_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--virtual-time-budget=30000", "--dump-dom")

if BROWSER is None and os.environ.get("CI"):
    raise RuntimeError("CI must have chromium for the browser test (.ci/run installs it with apt-get)")
pytestmark = pytest.mark.skipif(BROWSER is None, reason="no chromium on this machine (apt-get install chromium)")


class ChartCounter(HTMLParser):
    """Per chart div (``class="chart"``): its expected points and the marker paths, lines and legend entries
    drawn inside it."""

    def __init__(self) -> None:
        super().__init__()
        self.charts: list[dict[str, int]] = []
        self.depth = 0  # open elements inside the current chart (0: outside any chart)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = dict(attrs)
        classes = (values.get("class") or "").split()
        if self.depth == 0 and tag == "div" and "chart" in classes:
            self.charts.append({"id": values.get("id"), "expected": int(values.get("data-points") or 0),
                                "points": 0, "lines": 0, "legend": 0})
            self.depth = 1
            return
        if self.depth == 0:
            return
        if tag not in ("path", "rect", "circle", "line", "br", "img", "input"):
            self.depth += 1
        chart = self.charts[-1]
        chart["points"] += tag == "path" and "point" in classes
        chart["lines"] += tag == "path" and "js-line" in classes
        chart["legend"] += tag == "g" and "traces" in classes

    def handle_endtag(self, tag: str) -> None:
        if self.depth and tag not in ("path", "rect", "circle", "line", "br", "img", "input"):
            self.depth -= 1


@pytest.fixture(scope="module")
def report_dom(tmp_path_factory) -> tuple[Path, dict[str, str]]:
    """A report with every kind of chart, and the DOM of each of its pages (by file name)."""
    folder = tmp_path_factory.mktemp("interactive-report")
    studies = {
        "study_long_time_energy": long_time_energy(LongTimeEnergyConfig(
            duration_s=600.0, n_out=201, runs=(("explicit_euler", 0.2), ("verlet", 0.2))), progress=False),
        "study_stability": stability_sweep(StabilitySweepConfig(steps=200, kh=(0.5, 2.5, 3.5)), progress=False),
        "study_precession_latitude": precession_vs_latitude(PrecessionLatitudeConfig(
            duration_s=300.0, n_latitudes=5, amplitude_m=1.0), progress=False),
        "study_seed": seed_series(),
    }
    runs = results_fixture()  # one scene: every kind of chart, half the figures
    build_report(ReportInputs(runs=runs[runs["scene"] == "lab"], studies=studies, adequacy=adequacy_fixture()),
                 folder)
    return folder, {page.name: _dom(page, tmp_path_factory.mktemp("browser-profile"))
                    for page in report_pages(folder)}


def _dom(page: Path, profile: Path) -> str:
    """The DOM of ``page`` once its scripts have run, from headless chromium."""
    done = subprocess.run([BROWSER, *BROWSER_FLAGS, f"--user-data-dir={profile}", page.as_uri()],
                          capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert done.returncode == 0 and done.stdout, done.stderr[-2000:]
    return done.stdout


def test_every_chart_draws_its_points_lines_and_legend(report_dom: tuple[Path, dict[str, str]]) -> None:
    folder, doms = report_dom
    counter = ChartCounter()
    for page, dom in doms.items():
        before = len(counter.charts)
        counter.feed(dom)
        html = (folder / page).read_text(encoding="utf-8")
        assert len(counter.charts) - before == html.count("class='chart'") == html.count("<figure"), page
    assert len(doms) >= 4 and len(counter.charts) > len(doms)  # front, scene, studies and runs pages
    for chart in counter.charts:
        assert chart["points"] == chart["expected"], chart
        assert chart["points"] + chart["lines"] > 0, chart
        assert chart["legend"] > 0, chart
    # curves without markers: the seed section's four figures (the long-time energy chart marks explicit
    # Euler's divergence with ▲, as its static version does)
    assert sum(chart["expected"] == 0 for chart in counter.charts) == 4


def test_points_carry_their_run_for_the_hover(report_dom: tuple[Path, dict[str, str]]) -> None:
    folder, doms = report_dom
    assert "plotly-customdata" in doms["index.html"]  # plotly marks points that hold the run (hovertemplate fields)
    assert all("plotly-customdata" in dom for page, dom in doms.items() if page.startswith("scene_"))
    html = report_html(folder)
    for field in ("CPU time", "wall time", "nfev", "steps", "status", "all runge-kutta"):
        assert field in html


PROBE = """<script>
window.addEventListener('load', function () { setTimeout(function () {
  function plain(key, value) { return ArrayBuffer.isView(value) ? Array.from(value) : value; }
  function picked(trace) {
    var error = trace.error_x && trace.error_x.visible
      ? {array: trace.error_x.array, arrayminus: trace.error_x.arrayminus} : null;
    return {name: trace.name, mode: trace.mode, meta: trace.meta, xaxis: trace.xaxis, yaxis: trace.yaxis, x: trace.x,
            y: trace.y, marker: {symbol: trace.marker ? trace.marker.symbol : null}, error_x: error,
            customdata: trace.customdata};
  }
  var charts = [];
  document.querySelectorAll('div.chart').forEach(function (chart) {
    var full = chart._fullData || [];
    charts.push({id: chart.id, layout: JSON.parse(JSON.stringify(chart.layout, plain)),
                 data: JSON.parse(JSON.stringify(full.map(picked), plain)),
                 drawn: full.map(function (trace) {
                   return chart.querySelectorAll('g.trace' + trace.uid + ' path.point').length; })});
  });
  var probe = document.createElement('pre');
  probe.id = 'probe';
  probe.textContent = JSON.stringify(charts);
  document.body.appendChild(probe);
}, 0); });
</script>"""
"""Appended to a copy of index.html: once every chart is drawn, writes into the page each chart's traces as
plotly.js holds them after reading the page's JSON (``_fullData``: binary arrays decoded), its layout and the
marker paths drawn per trace."""


@pytest.fixture(scope="module")
def browser_charts(fixture_report: Path, tmp_path_factory) -> tuple[dict[str, oracle.Chart], list[dict]]:
    """The fixture report's charts as the browser holds them (by static file stem, as ``oracle.page_charts``),
    and the probe's raw entries."""
    entries = []
    for source in report_pages(fixture_report):  # a probing copy of each page, beside it (same links)
        page = source.with_name(f"probe_{source.name}")
        page.write_text(source.read_text(encoding="utf-8").replace("</body>", PROBE + "</body>"), encoding="utf-8")
        dom = _dom(page, tmp_path_factory.mktemp("probe-profile"))
        probe = re.search(r"<pre id=\"probe\">(.*?)</pre>", dom, re.S)
        assert probe is not None, dom[-2000:]
        entries += json.loads(probe.group(1).replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&"))
    by_id = {entry["id"]: entry for entry in entries}
    page_charts = oracle.page_charts(fixture_report)
    return ({stem: oracle.Chart(stem, chart.caption, {"data": by_id[chart.chart_id]["data"],
                                                       "layout": by_id[chart.chart_id]["layout"]}, chart.chart_id)
             for stem, chart in page_charts.items()}, entries)


@pytest.fixture(scope="module")
def database_rows(fixture_database: Path) -> pd.DataFrame:
    with sqlite3.connect(fixture_database) as connection:
        return pd.read_sql_query("SELECT * FROM runs", connection)


def test_the_browser_holds_each_scenes_runs(browser_charts, database_rows: pd.DataFrame) -> None:
    """The oracles of the page's JSON, on the numbers the browser decoded from it."""
    charts, _ = browser_charts
    assert set(charts) == oracle.expected_stems(database_rows)
    oracle.test_work_precision_charts_show_their_scene_and_verdict(charts, database_rows)
    oracle.test_the_pareto_trace_is_the_non_dominated_set(charts, database_rows)
    oracle.test_diverged_and_failed_runs_are_drawn_above_the_data(charts, database_rows)
    oracle.test_convergence_charts_show_each_scenes_fixed_step_runs(charts, database_rows)
    oracle.test_tolerance_charts_show_each_scenes_adaptive_runs(charts, database_rows)


def _axis_type(layout: dict, name: str, reference: str) -> str | None:
    """The type of axis ``reference`` ("x2" → layout["xaxis2"]) of a probed layout."""
    return layout.get(name + reference[1:], {}).get("type")


def test_each_trace_draws_one_marker_per_finite_point(browser_charts) -> None:
    _, entries = browser_charts
    checked = 0
    for entry in entries:
        for trace, drawn in zip(entry["data"], entry["drawn"], strict=True):
            if "markers" not in (trace.get("mode") or "") or trace.get("meta") == "family-toggle":
                continue
            x, y = oracle.decode(trace.get("x")), oracle.decode(trace.get("y"))
            keep = np.isfinite(x) & np.isfinite(y)
            if _axis_type(entry["layout"], "xaxis", trace.get("xaxis", "x")) == "log":
                keep &= x > 0
            if _axis_type(entry["layout"], "yaxis", trace.get("yaxis", "y")) == "log":
                keep &= y > 0
            assert drawn == int(keep.sum()), (entry["id"], trace.get("name"), drawn, int(keep.sum()))
            checked += drawn
    assert checked > 0


FIRST_SCREEN_PROBE = """<script>
window.addEventListener('load', function () { setTimeout(function () {
  function box(element) {
    if (!element) { return null; }
    var rect = element.getBoundingClientRect();
    return {top: rect.top, bottom: rect.bottom, left: rect.left, right: rect.right};
  }
  var probe = document.createElement('pre');
  probe.id = 'first-screen';
  probe.textContent = JSON.stringify({
    width: window.innerWidth, height: window.innerHeight, outer_width: window.outerWidth,
    outer_height: window.outerHeight,
    table: box(document.querySelector('.side-by-side .side-table table')),
    chart: box(document.querySelector('.side-by-side .side-chart div.chart')),
    drawn: document.querySelectorAll('.side-by-side .side-chart div.chart path.point').length > 0});
  document.body.appendChild(probe);
}, 0); });
</script>"""
"""Appended to a copy of index.html: the window's and the viewport's size and where the first recommendation
table and the chart beside it are, once the page is drawn and before any scroll."""

SCREEN_PX = (1400, 900)
"""The first screen the report is read on (issue: a screenshot in a real browser at 1400×900)."""


def _first_screen(page: Path, profile: Path, window_px: tuple[int, int]) -> dict:
    """The first-screen probe of ``page`` in headless chromium with a window of ``window_px``."""
    done = subprocess.run([BROWSER, *BROWSER_FLAGS, f"--window-size={window_px[0]},{window_px[1]}",
                           f"--user-data-dir={profile}", page.as_uri()],
                          capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert done.returncode == 0 and done.stdout, done.stderr[-2000:]
    probe = re.search(r"<pre id=\"first-screen\">(.*?)</pre>", done.stdout, re.S)
    assert probe is not None, done.stdout[-2000:]
    return json.loads(probe.group(1).replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&"))


def test_the_first_screen_shows_a_recommendation_and_its_chart(fixture_report: Path, tmp_path: Path) -> None:
    """In a 1400×900 viewport the first recommendation table and its work-precision chart lie wholly in view,
    side by side. Headless chromium's window holds its (invisible) frame too: a first run measures the frame
    (outer minus inner size), the second opens a window that much larger, and the viewport it measures must be
    1400×900."""
    page = fixture_report / "index_first_screen.html"
    page.write_text((fixture_report / "index.html").read_text(encoding="utf-8")
                    .replace("</body>", FIRST_SCREEN_PROBE + "</body>"), encoding="utf-8")
    trial = _first_screen(page, tmp_path / "trial", SCREEN_PX)
    frame_px = (trial["outer_width"] - trial["width"], trial["outer_height"] - trial["height"])
    screen = _first_screen(page, tmp_path / "screen", (SCREEN_PX[0] + frame_px[0], SCREEN_PX[1] + frame_px[1]))
    assert (screen["width"], screen["height"]) == SCREEN_PX, screen
    for name in ("table", "chart"):
        rect = screen[name]
        assert rect is not None, (name, screen)
        assert 0 <= rect["top"] < rect["bottom"] <= screen["height"], (name, screen)
        assert 0 <= rect["left"] < rect["right"] <= screen["width"], (name, screen)
    assert screen["table"]["right"] <= screen["chart"]["left"], screen  # beside it, not under or over it
    assert screen["drawn"], screen  # the chart has drawn its markers, not only its frame
