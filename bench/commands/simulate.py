"""``foucault-bench simulate``: the pendulum seen from above, with sliders, or saved as an animation
(``reports.simulate``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.validation import (
    coarse_steps_problem, finite_number, setting_problem, step_count_problem, suggestion,
)
from foucault_bench.bench.simulation_settings import SimulationSettings


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help with each option's default. The choices of ``--integrator`` and ``--model`` are not listed: finding
    them imports every integrator and model (numpy, numba, scipy: over a second), which ``--help`` must not
    wait for; a name that is not registered is answered with the list (``settings_from_args``)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        return action.help if action.default is None else super()._get_help_string(action)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    defaults = SimulationSettings()
    parser.formatter_class = _HelpFormatter
    parser.add_argument("--integrator", metavar="NAME", default=defaults.integrator,
                        help="registered integrator (an unknown name is answered with the list)")
    parser.add_argument("--model", metavar="NAME", default=defaults.model,
                        help="model (linear is the model of the exact-solution overlay; an unknown name is answered "
                        "with the list)")
    parser.add_argument("--hours", type=float, default=defaults.hours, help="simulated time (h)")
    parser.add_argument("--kh", type=float, default=None,
                        help="k·h for a fixed-step integrator, > 0 and at most one output interval (1/16 of a "
                             "period: k·h ≤ 2π/16), at most 1e10 steps (default: 0.05)")
    parser.add_argument("--tol", type=float, default=None,
                        help="tolerance for an adaptive one, in [2^-53, 1) (default: 1e-10)")
    parser.add_argument("--earth-rate", type=float, default=defaults.earth_rate_factor,
                        help="Earth's rate in multiples of the sidereal Ω_E (the slider spans 0.1-100); Ω must stay "
                             "below the pendulum's frequency √(g/L)")
    parser.add_argument("--latitude", type=float, default=defaults.latitude_deg, help="latitude (°, north +)")
    parser.add_argument("--length", type=float, default=defaults.length_m, help="string length (m)")
    parser.add_argument("--amplitude", type=float, default=defaults.amplitude_m,
                        help="release amplitude (m, below the length)")
    parser.add_argument("--save", metavar="FILE", type=Path, default=None,
                        help="write an animation (.gif, or .mp4 with ffmpeg) instead; its folder must exist and "
                             "be writable (checked before any work); the file is replaced only once complete")
    parser.add_argument("--frames", type=int, default=90,
                        help="frames of the animation, 2 to 200 (a GIF's frames are all held in memory: about "
                             "750 MB at 200)")
    parser.add_argument("--fps", type=int, default=20, help="frames per second of the animation, 1 to 50 (a GIF "
                                                            "cannot play faster)")


def settings_from_args(args: argparse.Namespace) -> SimulationSettings:
    """Validated settings, and a ``--save`` path that can be written; every problem is reported at once as an
    ``InputError``, before any work. The setting (``--kh``/``--tol``), the step count and Earth's rate go through
    the checks a matrix's scenes and sweeps go through (``bench.validation``,
    ``bench.problems.scenes.physical_limit_problems``)."""
    from foucault_bench.bench.problems.scenes import physical_limit_problems
    from foucault_bench.integrators import REGISTRY
    from foucault_bench.models import MODELS
    from foucault_bench.bench.simulation import MAX_OUTPUT_POINTS, OUTPUT_POINTS_PER_PERIOD, output_intervals
    from foucault_bench.reports.animation import MAX_FPS, MAX_FRAMES, save_path_problems

    problems = []
    if args.integrator not in REGISTRY:
        problems.append(f"unknown integrator {args.integrator!r}{suggestion(args.integrator, REGISTRY)}; "
                        f"known: {', '.join(sorted(REGISTRY))}")
    if args.model not in MODELS:
        problems.append(f"unknown model {args.model!r}{suggestion(args.model, MODELS)}; known: {', '.join(MODELS)}")
    if not finite_number(args.hours, positive=True):
        problems.append(f"--hours must be > 0, got {args.hours}")
    if args.save is not None:
        problems += save_path_problems(args.save)
    if not 2 <= args.frames <= MAX_FRAMES:
        problems.append(f"--frames must lie in [2, {MAX_FRAMES}], got {args.frames} (Pillow holds every frame of a "
                        "GIF in memory until it writes the file)")
    if not 1 <= args.fps <= MAX_FPS:
        problems.append(f"--fps must lie in [1, {MAX_FPS}], got {args.fps} (a GIF's frame delays are whole "
                        "hundredths of a second, and browsers slow those below 2/100 s)")
    adaptive = args.integrator in REGISTRY and REGISTRY[args.integrator].adaptive
    if adaptive and args.kh is not None or not adaptive and args.tol is not None:
        problems.append(f"{args.integrator} takes {'--tol' if adaptive else '--kh'}, not "
                        f"{'--kh' if adaptive else '--tol'}")
    key = "tol" if adaptive else "kh"
    setting = (args.tol if args.tol is not None else 1e-10) if adaptive else (args.kh if args.kh is not None else 0.05)
    message = setting_problem(key, setting)
    if message:
        problems.append(f"--{key}: {message}")
    if problems:
        raise InputError(problems)
    settings = SimulationSettings(earth_rate_factor=args.earth_rate, latitude_deg=args.latitude,
                                  length_m=args.length, amplitude_m=args.amplitude, hours=args.hours,
                                  model=args.model, integrator=args.integrator, setting=setting)
    try:
        params = settings.params()
    except ValueError as error:
        raise InputError(str(error)) from None
    problems = [f"the simulated pendulum: {problem}" for problem in physical_limit_problems(params)]
    points = OUTPUT_POINTS_PER_PERIOD * settings.hours * 3600.0 / params.small_swing_period_s + 1.0  # a float: no overflow
    if points > MAX_OUTPUT_POINTS:
        problems.append(f"{settings.hours:g} h of a {params.small_swing_period_s:.3g} s pendulum needs "
                        f"{points:.3g} output points, more than {MAX_OUTPUT_POINTS}: shorten --hours")
    elif not adaptive:
        intervals = output_intervals(settings, params)
        duration_s, k = settings.hours * 3600.0, params.pendulum_frequency_rad_s
        for message in (coarse_steps_problem([setting], k, duration_s / intervals, "this simulation's output grid"),
                        step_count_problem(setting, k, duration_s, "this simulation")):
            if message:
                problems.append(f"--kh: {message}")
    if problems:
        raise InputError(problems)
    return settings


def main(args: argparse.Namespace) -> int:
    settings = settings_from_args(args)
    if args.save is not None:
        from foucault_bench.reports.animation import save_animation

        path = save_animation(settings, args.save, args.frames, args.fps)
        print(f"animation written: {path}")
        return 0
    from foucault_bench.reports.simulate import show_interactive

    return show_interactive(settings)
