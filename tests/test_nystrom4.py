"""Nyström's fourth-order method for accelerations that depend on the velocity (``integrators.methods.nystrom4``):
its declared stability limit is the one its coefficients give. Its observed order is measured by the conformance
test of every built-in integrator (tests/test_selftest.py, on the models of ``ORDER_MODELS`` there)."""

from __future__ import annotations

import numpy as np


def test_nystrom4_declares_the_stability_limit_of_its_coefficients() -> None:
    """The spectral radius of Nyström 4's one-step matrix on ẍ = −x (step kh), from the coefficients, first
    exceeds 1 just above the declared limit and stays ≤ 1 below it."""
    from foucault_bench.integrators.methods.nystrom4 import Nystrom4

    def spectral_radius(kh: float) -> float:
        columns = []
        for y, v in ((1.0, 0.0), (0.0, 1.0)):
            k1 = -y
            k2 = -(y + kh / 2 * v + kh * kh / 8 * k1)
            k3 = k2  # same stage position, f independent of the velocity here
            k4 = -(y + kh * v + kh * kh / 2 * k3)
            columns.append((y + kh * v + kh * kh / 6 * (k1 + k2 + k3), v + kh / 6 * (k1 + 2 * k2 + 2 * k3 + k4)))
        return float(max(abs(np.linalg.eigvals(np.array(columns).T))))

    limit = Nystrom4.stability_limit_kh
    below = np.linspace(0.01, limit - 1e-4, 2000)
    assert all(spectral_radius(kh) <= 1.0 + 1e-12 for kh in below)
    assert spectral_radius(limit + 1e-4) > 1.0 + 1e-12
