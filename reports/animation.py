"""``foucault-bench simulate --save``: the simulation's view (``reports.simulate.SimulationView``) written as
an animation, GIF with Pillow or MP4 with ffmpeg (a clear error when ffmpeg is not installed). Its path is
checked before anything is computed (``save_path_problems``) and the file is written whole or not at all (a
temporary file renamed over it), with at most ``MAX_FRAMES`` frames at up to ``MAX_FPS`` frames per second."""

from __future__ import annotations

import os
import subprocess
import uuid
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.simulation_settings import SimulationSettings
from foucault_bench.reports.simulate import SimulationView

MAX_FRAMES = 200
"""Most frames a saved animation may have: 10 s at the default 20 fps. Pillow keeps every frame of a GIF in
memory until it writes the file (matplotlib's ``PillowWriter``): 200 frames of 800 × 480 pixels peaked at
750 MB resident (measured), and each frame is a full redraw (about 0.4 s on an idle core)."""
MAX_FPS = 50
"""Highest frame rate of a saved animation: a GIF stores each frame's delay in whole hundredths of a second,
and browsers slow delays below 2/100 s to about 1/10 s, so a GIF cannot play faster than 50 fps."""
SAVE_SUFFIXES = (".gif", ".mp4")
"""What ``--save`` writes: a GIF (Pillow) or an MP4 (ffmpeg)."""


ANIMATION_DPI = 80
"""Resolution of saved animations (a 10 × 6 in figure: 800 × 480 pixels)."""


def save_path_problems(path: Path) -> list[str]:
    """What keeps ``--save`` from writing ``path``, checked before any work (empty list: nothing): a suffix it
    can write (``SAVE_SUFFIXES``; ffmpeg installed for .mp4), an existing folder it may write in (never
    created), not a folder itself, and not a file the user may not write."""
    from matplotlib.animation import writers

    suffix = path.suffix.lower()
    if suffix not in SAVE_SUFFIXES:
        return [f"--save must end in {' or '.join(SAVE_SUFFIXES)}, got {path}"]
    if suffix == ".mp4" and not writers.is_available("ffmpeg"):
        return ["writing .mp4 needs ffmpeg, which is not installed (e.g. `apt-get install ffmpeg`); save a .gif instead"]
    folder = path.parent
    if path.is_dir():
        return [f"--save {path}: is a folder; give a file name"]
    if not folder.is_dir():
        return [f"--save {path}: the folder {folder} does not exist (it is not created)" if not folder.exists()
                else f"--save {path}: {folder} is not a folder"]
    if not os.access(folder, os.W_OK | os.X_OK):
        return [f"--save {path}: cannot write in the folder {folder}"]
    if path.exists() and not os.access(path, os.W_OK):
        return [f"--save {path}: the file is not writable"]
    return []


def save_animation(settings: SimulationSettings, path: Path, frames: int, fps: int) -> Path:
    """Write the view as an animation to ``path`` (.gif with Pillow, .mp4 with ffmpeg), drawing with Agg.

    The path is checked first (``save_path_problems``, ``InputError``). The animation is written to a
    temporary file in the same folder and renamed over ``path`` once complete (``os.replace``, atomic), so a
    full disk, a read-only folder or a kill leaves no partial file and any earlier file whole; a failed write is
    an ``InputError`` naming the reason."""
    from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    problems = save_path_problems(path)
    if problems:
        raise InputError(problems)
    writer = PillowWriter(fps=fps) if path.suffix.lower() == ".gif" else FFMpegWriter(fps=fps)
    figure = Figure(figsize=(10, 6))
    FigureCanvasAgg(figure)
    view = SimulationView(figure, settings, (0.08, 0.1, 0.5, 0.82))
    view.update(settings)
    if view.result is None:  # parameters the model refuses: the figure's notice says why
        raise InputError(" ".join(view.notice.get_text().split()))
    last = len(view.result.t_s) - 1
    indices = np.unique(np.linspace(0, last, max(2, min(frames, last + 1))).round().astype(int))
    animation = FuncAnimation(figure, lambda i: view.show_until(int(i)), frames=indices, blit=False)
    # the writers choose the format by the suffix: the temporary name keeps it
    temporary = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:8]}.partial{path.suffix}")
    try:
        animation.save(temporary, writer=writer, dpi=ANIMATION_DPI)
        os.replace(temporary, path)
    except (OSError, subprocess.CalledProcessError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
        raise InputError(f"--save {path}: the animation could not be written ({reason}); nothing was left "
                         "there") from None
    finally:
        temporary.unlink(missing_ok=True)
    return path
