"""The interactive simulation (reports.simulate), headless: moving a slider changes the plotted path and the
rate readout as the physics says (no precession at the equator, the sense flips in the south, the rate
scales with Earth's rate); the sliders keep to their grids and bound each other; what the figure says (title,
errors, divergence, Airy's rate) is true and inside it; --save writes an animation or says clearly why it
cannot, checks its path before any work and never leaves a partial file; bad settings are refused with the
words a matrix uses."""

from __future__ import annotations

import argparse
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.turning_points import azimuth_error_bound, rate_error_bound
from foucault_bench.bench.simulation import SimulationResult
from foucault_bench.reports.animation import save_animation
from foucault_bench.bench.simulation_settings import SimulationSettings
from foucault_bench.reports.simulate import (
    DEGREES_PER_HOUR_PER_RAD_S,
    VIEW_BOUND,
    WINDOW_TITLE,
    InteractiveSimulation,
    SimulationView,
    drawn_until,
    format_setting,
    open_window,
)
from foucault_bench.bench.commands.simulate import add_arguments, settings_from_args

SMALL = SimulationSettings(length_m=10.0, amplitude_m=0.5, hours=0.25, latitude_deg=48.8, integrator="verlet",
                           model="linear", setting=0.05)


@pytest.fixture(scope="module")
def app() -> InteractiveSimulation:
    figure = Figure(figsize=(12, 8))
    FigureCanvasAgg(figure)
    return InteractiveSimulation(figure, SMALL)


def _readout_rates(app: InteractiveSimulation) -> tuple[float, float]:
    """(measured, expected) in °/h parsed from the readout text: what the user sees."""
    text = app.view.readout.get_text()
    measured = float(re.search(r"measured:\s+([+-][0-9.]+)", text).group(1))
    expected = float(re.search(r"expected −ω sin φ:\s+([+-][0-9.]+)", text).group(1))
    return measured, expected


def _rate_tolerance(result: SimulationResult) -> float:
    """Bound (rad/s) on the measured rate's error for Verlet on the linear model. Its precession is exact
    (integrators.methods.verlet), so the error comes from locating the turning points: the grid interpolation
    (bench.problems.turning_points.azimuth_error_bound) plus the O((kh)²) mismatch between Verlet's velocities and the
    model's accelerations used by the interpolant, an azimuth error ≲ (a/k)(kh)²; turned into a slope error
    by bench.problems.turning_points.rate_error_bound."""
    params = result.settings.params()
    a_over_k = abs(params.vertical_rate_rad_s) / params.pendulum_frequency_rad_s
    azimuth = azimuth_error_bound(params, result.t_s[1] - result.t_s[0]) + a_over_k * result.settings.setting**2
    return rate_error_bound(result.turning_points[:, 0], azimuth) + 1e-15


def _path(app: InteractiveSimulation) -> tuple[np.ndarray, np.ndarray]:
    return app.view.drawn_path()


def test_initial_readout_matches_minus_omega_sin_phi(app: InteractiveSimulation) -> None:
    result = app.view.result
    assert result is not None and result.status == "ok"
    assert abs(result.measured_rate_rad_s - result.expected_rate_rad_s) <= _rate_tolerance(result)
    measured, expected = _readout_rates(app)
    assert expected == pytest.approx(result.expected_rate_rad_s * DEGREES_PER_HOUR_PER_RAD_S, abs=1e-4)
    assert measured < 0  # clockwise seen from above in the north
    east, north = _path(app)
    assert len(east) == len(result.t_s) and np.max(np.abs(north)) > 1e-3  # the plane has turned off East-West


def test_equator_no_precession(app: InteractiveSimulation) -> None:
    app.set_value("latitude_deg", 0.0)
    try:
        result = app.view.result
        assert abs(result.measured_rate_rad_s) <= 1e-12 * result.settings.earth_rate_rad_s
        east, north = _path(app)
        assert np.max(np.abs(east)) == pytest.approx(SMALL.amplitude_m, rel=1e-3)
        assert np.max(np.abs(north)) <= 1e-12 * SMALL.amplitude_m  # the swing stays on the East-West line
        measured, expected = _readout_rates(app)
        assert measured == 0.0 and expected == 0.0
    finally:
        app.set_value("latitude_deg", SMALL.latitude_deg)


def test_southern_latitude_flips_the_sense(app: InteractiveSimulation) -> None:
    north_rate = app.view.result.measured_rate_rad_s
    _, north_path = _path(app)
    app.set_value("latitude_deg", -SMALL.latitude_deg)
    try:
        south = app.view.result
        assert south.measured_rate_rad_s > 0  # counter-clockwise in the south
        assert south.measured_rate_rad_s == pytest.approx(-north_rate, rel=1e-12)  # mirror image
        _, south_path = _path(app)
        np.testing.assert_allclose(south_path, -north_path, rtol=0, atol=1e-12 * SMALL.amplitude_m)
        measured, expected = _readout_rates(app)
        assert measured > 0 and expected > 0
    finally:
        app.set_value("latitude_deg", SMALL.latitude_deg)


def test_doubling_earths_rate_doubles_the_measured_rate(app: InteractiveSimulation) -> None:
    single = app.view.result
    _, north_before = _path(app)
    app.set_value("earth_rate_factor", 2.0 * SMALL.earth_rate_factor)
    try:
        double = app.view.result
        assert double.expected_rate_rad_s == pytest.approx(2.0 * single.expected_rate_rad_s, rel=1e-15)
        tolerance = _rate_tolerance(single) + _rate_tolerance(double)
        assert abs(double.measured_rate_rad_s - 2.0 * single.measured_rate_rad_s) <= 2.0 * tolerance
        _, north_after = _path(app)
        # the plane turns twice as far: the largest northward excursion (A·sin of the turned angle) grows
        assert np.max(np.abs(north_after)) > 1.5 * np.max(np.abs(north_before))
    finally:
        app.set_value("earth_rate_factor", SMALL.earth_rate_factor)


def _inside_figure(figure: Figure, artist) -> bool:
    """Whether a text's drawn extent lies wholly inside the figure (what is cut off the canvas cannot be read)."""
    extent = artist.get_window_extent(figure.canvas.get_renderer())
    box = figure.bbox
    return box.x0 <= extent.x0 and extent.x1 <= box.x1 and box.y0 <= extent.y0 and extent.y1 <= box.y1


def test_amplitude_and_length_bound_each_other(app: InteractiveSimulation) -> None:
    """The amplitude slider stops below the length, the length slider above the amplitude; the title follows."""
    app.set_value("amplitude_m", SMALL.length_m + 1.0)
    try:
        settings = app.view.settings
        assert settings.amplitude_m == 9.95 and settings.length_m == SMALL.length_m  # largest 5 cm step below L
        assert app.view.result is not None and app.view.result.status == "ok"
        assert "A = 9.95 m" in app.view.axes.get_title() and app.sliders["amplitude_m"].valtext.get_text() == "9.95"
        app.set_value("length_m", 2.0)  # below the amplitude: the length stops at the first step above it
        assert app.view.settings.length_m == 10.0 and app.view.result is not None
        assert "L = 10.0 m" in app.view.axes.get_title()
    finally:
        app.set_value("amplitude_m", SMALL.amplitude_m)
        app.set_value("length_m", SMALL.length_m)
    assert app.view.settings == SMALL


@pytest.mark.parametrize(("requested", "landed", "shown"), [
    (0.115385, 0.0, "0.0"), (0.3, 0.0, "0.0"), (-0.45, 0.0, "0.0"), (0.6, 1.0, "1.0"), (89.7, 90.0, "90.0"),
    (-89.6, -90.0, "-90.0"), (37.44, 37.4, "37.4")])
def test_latitude_moves_in_tenths_and_snaps_to_equator_and_poles(app: InteractiveSimulation, requested: float,
                                                                  landed: float, shown: str) -> None:
    app.set_value("latitude_deg", requested)
    try:
        assert app.view.settings.latitude_deg == landed
        assert f"φ = {shown}°" in app.view.axes.get_title()
        assert app.sliders["latitude_deg"].valtext.get_text() == shown
    finally:
        app.set_value("latitude_deg", SMALL.latitude_deg)


def test_length_and_amplitude_steps(app: InteractiveSimulation) -> None:
    app.set_value("length_m", 12.26)
    app.set_value("amplitude_m", 0.512)
    try:
        assert (app.view.settings.length_m, app.view.settings.amplitude_m) == (12.5, 0.5)
        assert "L = 12.5 m, A = 0.50 m" in app.view.axes.get_title()
    finally:
        app.set_value("length_m", SMALL.length_m)


def test_earths_rate_slider_is_logarithmic(app: InteractiveSimulation) -> None:
    """1-5 Ω_E takes log10(5)/3 = 23 % of the slider (4 % on a linear 0-100 one) in steps of 0.1 Ω_E."""
    slider = app.sliders["earth_rate_factor"]
    assert (slider.valmin, slider.valmax) == (-1.0, 2.0)
    app.set_value("earth_rate_factor", 2.37)
    try:
        assert app.view.settings.earth_rate_factor == 2.4
        assert slider.val == pytest.approx(math.log10(2.4), abs=1e-15)
        assert "ω = 2.4 Ω_E" in app.view.axes.get_title() and slider.valtext.get_text() == "2.4"
        app.set_value("earth_rate_factor", 0.123)
        assert app.view.settings.earth_rate_factor == 0.12 and slider.valtext.get_text() == "0.12"
    finally:
        app.set_value("earth_rate_factor", SMALL.earth_rate_factor)


def test_off_grid_command_line_values_are_printed_in_full() -> None:
    """A value given on the command line is simulated as given, so it is printed as given."""
    assert format_setting("latitude_deg", 48.846) == "48.846" and format_setting("latitude_deg", 48.8) == "48.8"
    figure = Figure(figsize=(12, 8))
    FigureCanvasAgg(figure)
    view = SimulationView(figure, SMALL, (0.07, 0.36, 0.5, 0.58))
    view.update(replace(SMALL, latitude_deg=48.846, hours=0.02))
    assert "φ = 48.846°" in view.axes.get_title()


def test_command_line_values_outside_a_slider_start_it_at_its_end() -> None:
    """``--earth-rate 0`` (no rotation) has no place on a log axis: the slider starts at its left end, the
    simulation and its labels keep 0 until the slider moves."""
    figure = Figure(figsize=(12, 8))
    FigureCanvasAgg(figure)
    simulation = InteractiveSimulation(figure, replace(SMALL, earth_rate_factor=0.0, length_m=150.0, hours=0.02))
    assert simulation.view.result.expected_rate_rad_s == 0.0
    assert simulation.sliders["earth_rate_factor"].val == -1.0 and simulation.sliders["length_m"].val == 100.0
    assert simulation.sliders["earth_rate_factor"].valtext.get_text() == "0"
    assert "ω = 0 Ω_E" in simulation.view.axes.get_title() and "L = 150.0 m" in simulation.view.axes.get_title()


def test_refused_parameters_are_shown_in_full_inside_the_figure(app: InteractiveSimulation) -> None:
    view = app.view
    bad = replace(SMALL, length_m=3.0, amplitude_m=7.25)  # no slider reaches it; the command line refuses it too
    view.update(bad)
    try:
        assert view.result is None and len(_path(app)[0]) == 0
        shown = view.notice.get_text().replace("\n", " ")
        with pytest.raises(ValueError) as error:
            bad.params()
        assert shown == f"cannot simulate: {error.value}"  # in full, wrapped, not cut
        assert _inside_figure(view.figure, view.notice)
        assert "L = 3.0 m, A = 7.25 m" in view.axes.get_title()  # the title says what was asked
    finally:
        view.update(SMALL)
    assert not view.notice.get_visible() and _inside_figure(view.figure, view.readout)


def test_a_diverging_run_stays_in_view_and_says_when_it_diverged() -> None:
    """Explicit Euler's amplitude grows as (1 + (kh)²)^(n/2) (Hairer-Lubich-Wanner I.1): at kh = 0.2 it passes
    1.2 A within ~20 periods and the integrator stops it at 1000 L."""
    figure = Figure(figsize=(12, 8))
    FigureCanvasAgg(figure)
    settings = replace(SMALL, integrator="explicit_euler", setting=0.2, hours=0.5)
    view = SimulationView(figure, settings, (0.07, 0.36, 0.5, 0.58))
    view.update(settings)
    result = view.result
    assert result.status == "diverged"
    drawn = drawn_until(result)
    reach = np.hypot(result.numeric[:, 0], result.numeric[:, 1])
    assert 0 < drawn < len(result.t_s) and reach[drawn] > VIEW_BOUND * settings.amplitude_m
    east, north = view.drawn_path()
    assert len(east) == drawn and np.max(np.hypot(east, north)) <= VIEW_BOUND * settings.amplitude_m
    assert view.axes.get_xlim()[1] == pytest.approx(1.1 * VIEW_BOUND * settings.amplitude_m)
    notice = view.notice.get_text().replace("\n", " ")
    assert "explicit_euler run diverged after" in notice and f"t = {result.t_s[drawn]:.4g} s" in notice
    assert re.search(r"after \d+ of \d+ steps \(t = [0-9.]+ s\)", notice)
    assert view.notice.get_visible() and _inside_figure(figure, view.notice)


def test_spherical_model_shows_airys_rate() -> None:
    """At θ₀ = A/L = 0.2 Airy's (3/8)θ₀² is 1.5 % of the rate; the measurement follows it. Bound: the terms Airy
    neglects (c₄θ₀⁴ + c₃θ₀³ cot φ, |c₄| ≤ 0.08, |c₃| ≤ 0.27: tests/test_verdicts.py, here ½ each) plus the
    measurement bound."""
    figure = Figure(figsize=(12, 8))
    FigureCanvasAgg(figure)
    settings = replace(SMALL, model="spherical", amplitude_m=2.0)
    view = SimulationView(figure, settings, (0.07, 0.36, 0.5, 0.58))
    view.update(settings)
    result = view.result
    theta0 = settings.amplitude_m / settings.length_m
    airy = result.expected_rate_rad_s * (1.0 - 0.375 * theta0**2)
    assert result.airy_rate_rad_s == pytest.approx(airy, rel=1e-15)
    shown = float(re.search(r"Airy −ω sin φ \(1 − 3θ₀²/8\):\s+([+-][0-9.]+)", view.readout.get_text()).group(1))
    assert shown == pytest.approx(airy * DEGREES_PER_HOUR_PER_RAD_S, abs=1e-4)
    params = settings.params()
    cot_phi = abs(math.cos(params.latitude_rad) / math.sin(params.latitude_rad))
    neglected = (0.5 * theta0**4 + 0.5 * theta0**3 * cot_phi) * abs(result.expected_rate_rad_s)
    assert abs(result.measured_rate_rad_s - airy) <= neglected + _rate_tolerance(result)
    assert abs(result.measured_rate_rad_s - result.expected_rate_rad_s) > 2.0 * (neglected + _rate_tolerance(result))
    assert _inside_figure(figure, view.readout)
    # the planar models have no Airy line
    view.update(replace(settings, model="linear"))
    assert view.result.airy_rate_rad_s is None and "Airy" not in view.readout.get_text()


def test_trail_fades_under_the_exact_solution_and_turning_points(app: InteractiveSimulation) -> None:
    trail = app.view.trail
    alphas = [line.get_alpha() for line in trail]
    assert alphas == sorted(alphas) and alphas[0] < 0.5 * alphas[-1] and alphas[-1] == 1.0
    top = max(line.get_zorder() for line in trail)
    assert app.view.analytic_line.get_zorder() > top and app.view.turning_dots.get_zorder() > top


def test_the_window_has_a_name() -> None:
    import matplotlib.pyplot as plt

    simulation = open_window(replace(SMALL, hours=0.02))
    try:
        assert simulation.view.figure.canvas.manager.get_window_title() == WINDOW_TITLE == "foucault-bench simulate"
    finally:
        plt.close(simulation.view.figure)


def test_help_shows_defaults_and_an_unknown_name_lists_the_choices() -> None:
    from foucault_bench.integrators.registry import REGISTRY
    from foucault_bench.models import MODELS

    parser = argparse.ArgumentParser(prog="foucault-bench simulate")
    add_arguments(parser)
    with pytest.raises(InputError) as error:
        settings_from_args(parser.parse_args(["--integrator", "nope", "--model", "nope"]))
    assert all(name in " ".join(error.value.problems) for name in [*REGISTRY, *MODELS])
    text = " ".join(parser.format_help().split())
    defaults = SimulationSettings()
    for value in (defaults.latitude_deg, defaults.length_m, defaults.amplitude_m, defaults.hours):
        assert f"(default: {value})" in text
    assert "(default: 0.05)" in text and "(default: 1e-10)" in text and "(default: None)" not in text


def test_save_writes_a_gif_with_the_requested_frames(tmp_path: Path) -> None:
    from PIL import Image

    path = save_animation(SimulationSettings(length_m=10.0, amplitude_m=0.5, hours=0.02), tmp_path / "swing.gif",
                          frames=4, fps=5)
    with Image.open(path) as image:
        assert image.format == "GIF" and image.n_frames == 4


def test_mp4_without_ffmpeg_is_a_clear_error(tmp_path: Path) -> None:
    from matplotlib.animation import writers

    if writers.is_available("ffmpeg"):
        path = save_animation(SimulationSettings(length_m=10.0, amplitude_m=0.5, hours=0.02), tmp_path / "s.mp4",
                              frames=3, fps=5)
        assert path.stat().st_size > 0
        return
    with pytest.raises(InputError, match="ffmpeg"):
        save_animation(SMALL, tmp_path / "swing.mp4", frames=3, fps=5)


def test_bad_arguments_are_reported_together() -> None:
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(["--integrator", "nope", "--hours", "-1", "--save", "x.avi"])
    with pytest.raises(InputError) as error:
        settings_from_args(args)
    problems = error.value.problems
    assert any("nope" in p for p in problems) and any("--hours" in p for p in problems)
    assert any(".gif or .mp4" in p for p in problems)
    args = parser.parse_args(["--integrator", "cvode_adams", "--kh", "0.1"])
    with pytest.raises(InputError, match="--tol"):
        settings_from_args(args)
    assert math.isclose(settings_from_args(parser.parse_args(["--integrator", "cvode_adams"])).setting, 1e-10)


# --- bad input and --save: refused before any work, written whole or not at all ------------------------------

TINY = ["--length", "10", "--amplitude", "0.5", "--hours", "0.02", "--frames", "2", "--fps", "5"]


def _no_work(monkeypatch) -> None:
    """Make any simulation an error, so that a refusal is known to come before the work."""
    import foucault_bench.reports.simulate as simulate_module

    def refuse(*_args, **_kwargs):
        raise AssertionError("the simulation ran before the arguments were refused")

    monkeypatch.setattr(simulate_module, "simulate", refuse)


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_save_into_a_missing_folder_creates_no_folder_and_does_no_work(tmp_path: Path, monkeypatch, capsys) -> None:
    from foucault_bench.bench.cli import main as cli_main

    _no_work(monkeypatch)
    target = tmp_path / "missing" / "deeper" / "swing.gif"
    assert cli_main(["simulate", "--save", str(target), *TINY]) == 2
    assert "does not exist" in _one_error_line(capsys)
    assert list(tmp_path.iterdir()) == []  # the old code made missing/deeper (at the root for /nonexistent/x.gif)


def test_save_into_a_folder_it_cannot_write_is_refused_before_any_work(tmp_path: Path, monkeypatch, capsys) -> None:
    """A folder without write permission (os.access says so; root would bypass a chmod, so access is what
    the check asks and what the test sets) is one line, before the simulation."""
    import os

    from foucault_bench.bench.cli import main as cli_main

    _no_work(monkeypatch)
    folder = tmp_path / "read_only"
    folder.mkdir()
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda path, mode, **kw: Path(path) != folder and real_access(path, mode, **kw))
    assert cli_main(["simulate", "--save", str(folder / "swing.gif"), *TINY]) == 2
    assert "cannot write in the folder" in _one_error_line(capsys)
    assert list(folder.iterdir()) == []


def test_a_failed_write_leaves_the_old_file_whole_and_no_partial_file(tmp_path: Path, monkeypatch, capsys) -> None:
    """A full disk while the GIF is written (ENOSPC after some bytes): one line naming the reason, the
    earlier file at --save unchanged, no temporary file left."""
    import errno
    import os

    from PIL import Image

    from foucault_bench.bench.cli import main as cli_main

    target = tmp_path / "swing.gif"
    target.write_bytes(b"the earlier animation")

    def disk_full(image, fp, *args, **kwargs):
        Path(fp).write_bytes(b"GIF89a partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Image.Image, "save", disk_full)
    assert cli_main(["simulate", "--save", str(target), *TINY]) == 2
    assert os.strerror(errno.ENOSPC) in _one_error_line(capsys)
    assert target.read_bytes() == b"the earlier animation"
    assert [path.name for path in tmp_path.iterdir()] == ["swing.gif"]


def test_a_saved_animation_replaces_the_file_and_leaves_nothing_else(tmp_path: Path, capsys) -> None:
    from PIL import Image

    from foucault_bench.bench.cli import main as cli_main

    target = tmp_path / "swing.gif"
    target.write_bytes(b"the earlier animation")
    assert cli_main(["simulate", "--save", str(target), *TINY]) == 0
    with Image.open(target) as image:
        assert image.format == "GIF" and image.n_frames == 2
    assert [path.name for path in tmp_path.iterdir()] == ["swing.gif"]


@pytest.mark.parametrize(("argv", "expected"), [
    (["--integrator", "cvode_bdf", "--tol", "1e-300"], "below the double-precision unit roundoff"),  # hung before
    (["--kh", "1e-12"], "steps in this simulation"),
    (["--kh", "0.5"], "at most one output interval"),
    (["--kh", "nan"], "step size must be > 0"),
    (["--frames", str(10**8)], "--frames must lie in [2, 200]"),  # 19 s and 1.8 GB before
    (["--fps", "1000"], "--fps must lie in [1, 50]"),
    (["--earth-rate", "1e10"], "must be below the pendulum's own frequency"),
    (["--hours", "1e306"], "output points, more than"),  # refused before too: kept so that the grid never overflows
])
def test_simulate_refuses_what_would_hang_or_exhaust_memory(argv: list[str], expected: str, monkeypatch) -> None:
    _no_work(monkeypatch)
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    with pytest.raises(InputError) as error:
        settings_from_args(parser.parse_args(argv))
    assert len(error.value.problems) == 1 and expected in error.value.problems[0], error.value.problems


def test_simulate_and_matrices_refuse_a_setting_in_the_same_words() -> None:
    """One validation function (bench.validation.setting_problem) for both, not two near-copies."""
    from foucault_bench.bench.run.matrix import parse_matrix

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    for option, key, integrator, value in (("--tol", "tol", "cvode_bdf", 1e-300), ("--kh", "kh", "rk4", -0.5)):
        with pytest.raises(InputError) as from_simulate:
            settings_from_args(parser.parse_args(["--integrator", integrator, option, str(value)]))
        with pytest.raises(InputError) as from_matrix:
            parse_matrix({"scenes": ["seed_2min"], "integrators": [integrator], key: [value]}, source="m")
        (simulate_message,) = from_simulate.value.problems
        (matrix_message,) = from_matrix.value.problems
        assert simulate_message.removeprefix(f"{option}: ") == matrix_message.removeprefix(f"m: {key}: ")
