"""Model 1: the linear planar Foucault pendulum (seed eqs. 6-7).

    ẍ = −k²x + 2aẏ,   ÿ = −k²y − 2aẋ,   k² = g/L,   a = Ω_E sin φ

Source: seed note eqs. (6)-(7), with its ω cos λ (λ = colatitude) written as Ω_E sin φ (φ = latitude);
models/README.md "Linear planar model". Frame x South, y East, z Up. The Coriolis force does no work, so
E = ½(ẋ² + ẏ²) + ½k²(x² + y²) is conserved exactly; the exact solution is in ``models.analytic``.
"""

from foucault_bench.models.base import Model
from foucault_bench.models.parameters import P_K2, P_OMEGA_Z


def free_force(m, x, y, z, vx, vy, vz, p):
    """Acceleration (m/s²) of seed eqs. (6)-(7); z and vz are unused (planar model)."""
    k2 = p[P_K2]
    a = p[P_OMEGA_Z]
    return -k2 * x + 2.0 * a * vy, -k2 * y - 2.0 * a * vx, 0.0 * z


def energy(m, x, y, vx, vy, p):
    """E = ½(ẋ² + ẏ²) + ½k²(x² + y²) per unit mass (J/kg), conserved exactly (models/README.md "Energy and the Jacobi
    integral")."""
    return 0.5 * (vx * vx + vy * vy) + 0.5 * p[P_K2] * (x * x + y * y)


MODEL = Model(
    name="linear",
    title="Linear planar (seed eqs. 6-7)",
    geometry="plane",
    free_force=free_force,
    energy=energy,
    energy_name="E = ½|v|² + ½k²|r|²",
    conserves_energy=True,
    hamiltonian=True,
)
