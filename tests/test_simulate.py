"""The interactive simulation (reports.simulate), headless: moving a slider changes the plotted path and the
rate readout as the physics says (no precession at the equator, the sense flips in the south, the rate
scales with Earth's rate), and --save writes an animation or says clearly why it cannot."""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.verdicts.turning_points import azimuth_error_bound, rate_error_bound
from foucault_bench.reports.simulate import (
    DEGREES_PER_HOUR_PER_RAD_S,
    InteractiveSimulation,
    SimulationResult,
    SimulationSettings,
    save_animation,
)
from foucault_bench.bench.commands.simulate import add_arguments, settings_from_args

SMALL = SimulationSettings(length_m=10.0, amplitude_m=0.5, hours=0.25, latitude_deg=48.846, integrator="verlet",
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
    (integrators.verlet), so the error comes from locating the turning points: the grid interpolation
    (bench.verdicts.turning_points.azimuth_error_bound) plus the O((kh)²) mismatch between Verlet's velocities and the
    model's accelerations used by the interpolant, an azimuth error ≲ (a/k)(kh)²; turned into a slope error
    by bench.verdicts.turning_points.rate_error_bound."""
    params = result.settings.params()
    a_over_k = abs(params.vertical_rate_rad_s) / params.pendulum_frequency_rad_s
    azimuth = azimuth_error_bound(params, result.t_s[1] - result.t_s[0]) + a_over_k * result.settings.setting**2
    return rate_error_bound(result.turning_points[:, 0], azimuth) + 1e-15


def _path(app: InteractiveSimulation) -> tuple[np.ndarray, np.ndarray]:
    east, north = app.view.numeric_line.get_data()
    return np.asarray(east, dtype=float), np.asarray(north, dtype=float)


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
    app.sliders["latitude_deg"].set_val(0.0)
    try:
        result = app.view.result
        assert abs(result.measured_rate_rad_s) <= 1e-12 * result.settings.earth_rate_rad_s
        east, north = _path(app)
        assert np.max(np.abs(east)) == pytest.approx(SMALL.amplitude_m, rel=1e-3)
        assert np.max(np.abs(north)) <= 1e-12 * SMALL.amplitude_m  # the swing stays on the East-West line
        measured, expected = _readout_rates(app)
        assert measured == 0.0 and expected == 0.0
    finally:
        app.sliders["latitude_deg"].set_val(SMALL.latitude_deg)


def test_southern_latitude_flips_the_sense(app: InteractiveSimulation) -> None:
    north_rate = app.view.result.measured_rate_rad_s
    _, north_path = _path(app)
    app.sliders["latitude_deg"].set_val(-SMALL.latitude_deg)
    try:
        south = app.view.result
        assert south.measured_rate_rad_s > 0  # counter-clockwise in the south
        assert south.measured_rate_rad_s == pytest.approx(-north_rate, rel=1e-12)  # mirror image
        _, south_path = _path(app)
        np.testing.assert_allclose(south_path, -north_path, rtol=0, atol=1e-12 * SMALL.amplitude_m)
        measured, expected = _readout_rates(app)
        assert measured > 0 and expected > 0
    finally:
        app.sliders["latitude_deg"].set_val(SMALL.latitude_deg)


def test_doubling_earths_rate_doubles_the_measured_rate(app: InteractiveSimulation) -> None:
    single = app.view.result
    _, north_before = _path(app)
    app.sliders["earth_rate_factor"].set_val(2.0 * SMALL.earth_rate_factor)
    try:
        double = app.view.result
        assert double.expected_rate_rad_s == pytest.approx(2.0 * single.expected_rate_rad_s, rel=1e-15)
        tolerance = _rate_tolerance(single) + _rate_tolerance(double)
        assert abs(double.measured_rate_rad_s - 2.0 * single.measured_rate_rad_s) <= 2.0 * tolerance
        _, north_after = _path(app)
        # the plane turns twice as far: the largest northward excursion (A·sin of the turned angle) grows
        assert np.max(np.abs(north_after)) > 1.5 * np.max(np.abs(north_before))
    finally:
        app.sliders["earth_rate_factor"].set_val(SMALL.earth_rate_factor)


def test_an_amplitude_beyond_the_length_is_reported_not_raised(app: InteractiveSimulation) -> None:
    app.sliders["amplitude_m"].set_val(SMALL.length_m + 1.0)
    try:
        assert app.view.result is None
        assert "cannot simulate" in app.view.readout.get_text() and "amplitude_m" in app.view.readout.get_text()
        assert len(_path(app)[0]) == 0
    finally:
        app.sliders["amplitude_m"].set_val(SMALL.amplitude_m)
    assert app.view.result is not None


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
