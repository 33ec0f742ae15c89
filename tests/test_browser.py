"""The interactive report in a real headless browser: index.html is opened from disk with no network, and every
plotly chart must have drawn its points (each chart's div says how many markers its data has,
``reports.interactive.drawn_points``; the browser's DOM must hold exactly that many marker paths) and its
lines and legend. Needs Debian's ``chromium`` (installed by .ci/run); skipped when it is absent outside CI."""

from __future__ import annotations

import os
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest

from foucault_bench.reports.build import ReportInputs, build_report
from foucault_bench.reports.studies import (
    LongTimeEnergyConfig,
    PrecessionLatitudeConfig,
    StabilitySweepConfig,
    long_time_energy,
    precession_vs_latitude,
    stability_sweep,
)
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
def report_dom(tmp_path_factory) -> tuple[Path, str]:
    folder = tmp_path_factory.mktemp("interactive-report")
    studies = {
        "study_long_time_energy": long_time_energy(LongTimeEnergyConfig(
            duration_s=600.0, n_out=201, runs=(("explicit_euler", 0.2), ("verlet", 0.2))), progress=False),
        "study_stability": stability_sweep(StabilitySweepConfig(steps=200, kh=(0.5, 2.5, 3.5)), progress=False),
        "study_precession_latitude": precession_vs_latitude(PrecessionLatitudeConfig(
            duration_s=300.0, n_latitudes=5, amplitude_m=1.0), progress=False),
    }
    runs = results_fixture()  # one scene: every kind of chart, half the figures
    build_report(ReportInputs(runs=runs[runs["scene"] == "lab"], studies=studies, adequacy=adequacy_fixture(),
                              include_seed=True), folder)
    profile = tmp_path_factory.mktemp("browser-profile")
    done = subprocess.run([BROWSER, *BROWSER_FLAGS, f"--user-data-dir={profile}", (folder / "index.html").as_uri()],
                          capture_output=True, text=True, timeout=50, stdin=subprocess.DEVNULL)
    assert done.returncode == 0 and done.stdout, done.stderr[-2000:]
    return folder, done.stdout


def test_every_chart_draws_its_points_lines_and_legend(report_dom: tuple[Path, str]) -> None:
    folder, dom = report_dom
    counter = ChartCounter()
    counter.feed(dom)
    html = (folder / "index.html").read_text(encoding="utf-8")
    assert len(counter.charts) == html.count("class='chart'") == html.count("<figure>")  # every chart interactive
    for chart in counter.charts:
        assert chart["points"] == chart["expected"], chart
        assert chart["points"] + chart["lines"] > 0, chart
        assert chart["legend"] > 0, chart
    # curves without markers: the long-time energy chart and the seed section's four figures
    assert sum(chart["expected"] == 0 for chart in counter.charts) == 5


def test_points_carry_their_run_for_the_hover(report_dom: tuple[Path, str]) -> None:
    folder, dom = report_dom
    assert "plotly-customdata" in dom  # plotly marks points that hold the run (hovertemplate fields)
    html = (folder / "index.html").read_text(encoding="utf-8")
    for field in ("CPU time", "wall time", "nfev", "steps", "status", "all runge-kutta"):
        assert field in html
