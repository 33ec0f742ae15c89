"""The swing's ellipse as verdicts: its semi-minor axis and the canonical angular momentum about the vertical,
each against the reference on the output grid.

A swing that opens into an ellipse precesses by itself: Airy's precession on the sphere is (3/8) k a_e b_e/L²
(models/README.md "Airy precession"), an anisotropic support turns the plane through the ellipticity it builds
(models/README.md "Anisotropic support"), and an integrator that creates a spurious ellipse creates spurious
precession. The rate columns see this late and integrated; these columns see the ellipse itself.

* **Canonical angular momentum** about the vertical, per unit mass, ℓ_c = x ẏ − y ẋ + a (x² + y²)
  (a = Ω_E sin φ): the vertical component of r × p with the canonical momentum p = ṙ + ω×r of the planar models
  (models/README.md "Energy and the Jacobi integral"). The linear model conserves it exactly (it is symmetric
  about the vertical); a support anisotropy, the sphere's horizontal ω and drag change it.
* **Semi-minor axis** b_e of the osculating ellipse of the small-swing oscillator of frequency k, seen from the
  frame that turns at −a (where the linear model's swing is a fixed narrow ellipse, models/README.md "Closed
  forms"): with the velocity there, p = ṙ + a ẑ×r, s = |r|² + |p|²/k² = a_e² + b_e² and ℓ_c = k a_e b_e,
  b_e = ½ (√(s + 2|ℓ_c|/k) − √(s − 2|ℓ_c|/k)); exact to the relative (a/k)² for the linear model, the leading
  order otherwise (horizontal components on the sphere).

Columns: max over the grid of |ℓ_c − ℓ_c,ref| / (k A²) and of |b_e − b_e,ref| / A (bench/schema.py).
"""

from __future__ import annotations

import numpy as np

from foucault_bench.bench.problems.turning_points import finite_prefix
from foucault_bench.models import PendulumParameters


def canonical_angular_momentum(params: PendulumParameters, y: np.ndarray) -> np.ndarray:
    """ℓ_c = x ẏ − y ẋ + a (x² + y²) (m²/s) at every row (x, y, ẋ, ẏ)."""
    x, yy, vx, vy = y[:, 0], y[:, 1], y[:, 2], y[:, 3]
    return x * vy - yy * vx + params.vertical_rate_rad_s * (x * x + yy * yy)


def semi_minor_axis(params: PendulumParameters, y: np.ndarray) -> np.ndarray:
    """b_e (m) of the osculating small-swing ellipse at every row, seen from the frame that turns with the
    textbook precession (module docstring)."""
    k = params.pendulum_frequency_rad_s
    a = params.vertical_rate_rad_s
    x, yy = y[:, 0], y[:, 1]
    px, py = y[:, 2] - a * yy, y[:, 3] + a * x  # ṙ + a ẑ×r: the velocity in the frame turning at −a
    s = x * x + yy * yy + (px * px + py * py) / (k * k)
    twice_area = 2.0 * np.abs(canonical_angular_momentum(params, y)) / k
    return 0.5 * (np.sqrt(s + twice_area) - np.sqrt(np.maximum(s - twice_area, 0.0)))


def ellipse_errors(params: PendulumParameters, y: np.ndarray, reference_y: np.ndarray) -> dict[str, float]:
    """``canonical_angular_momentum_ref_error`` and ``semi_minor_axis_ref_error`` of a run (NaN without two
    finite rows)."""
    n = min(finite_prefix(y), finite_prefix(reference_y))
    if n < 2:
        return {"canonical_angular_momentum_ref_error": float("nan"), "semi_minor_axis_ref_error": float("nan")}
    amplitude = params.amplitude_m
    scale = params.pendulum_frequency_rad_s * amplitude * amplitude
    momentum = np.abs(canonical_angular_momentum(params, y[:n]) - canonical_angular_momentum(params, reference_y[:n]))
    axis = np.abs(semi_minor_axis(params, y[:n]) - semi_minor_axis(params, reference_y[:n]))
    return {"canonical_angular_momentum_ref_error": float(np.max(momentum)) / scale,
            "semi_minor_axis_ref_error": float(np.max(axis)) / amplitude}
