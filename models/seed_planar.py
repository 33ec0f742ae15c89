"""Model 2: the seed's nonlinear planar pendulum (seed eqs. 4-5), re-expressed with latitude.

    ẍ = −(g/L)x + (2Ω_E cos φ / L)·x·ẏ + 2Ω_E sin φ·ẏ
    ÿ = −(g/L)y + (2Ω_E cos φ / L)·y·ẏ − 2Ω_E sin φ·ẋ

Source: seed note eqs. (3)-(5) (its sin λ = cos φ, cos λ = sin φ); models/README.md "The seed's planar model".
Frame x South, y East, z Up. The x·ẏ and y·ẏ terms come from the tension T = m(g − 2Ω_E cos φ·ẏ) (seed eq. 3: the
vertical Coriolis force) with every ż term dropped, while the geometric nonlinearity of the same swing (order
(A/L)², about 100× larger for real pendulums) is dropped too. The model therefore conserves **no** energy:

    dE/dt = (2Ω_E cos φ / L)·ẏ·(xẋ + yẏ)   for   E = ½(ẋ² + ẏ²) + ½(g/L)(x² + y²),

which the suite reports as a drift of the model, not of the integrator. In our parameter vector
ω_x = −Ω_E cos φ, so the tension coefficient is written −2ω_x / L.
"""

from foucault_bench.models.base import Model
from foucault_bench.models.parameters import P_K2, P_LENGTH, P_OMEGA_X, P_OMEGA_Z


def free_force(m, x, y, z, vx, vy, vz, p):
    """Acceleration (m/s²) of seed eqs. (4)-(5); z and vz are unused (planar model)."""
    k2 = p[P_K2]
    a = p[P_OMEGA_Z]
    tension = -2.0 * p[P_OMEGA_X] / p[P_LENGTH] * vy
    return -k2 * x + tension * x + 2.0 * a * vy, -k2 * y + tension * y - 2.0 * a * vx, 0.0 * z


def energy(m, x, y, vx, vy, p):
    """E = ½(ẋ² + ẏ²) + ½(g/L)(x² + y²) per unit mass (J/kg); *not* conserved by this model (see module doc)."""
    return 0.5 * (vx * vx + vy * vy) + 0.5 * p[P_K2] * (x * x + y * y)


MODEL = Model(
    name="seed_planar",
    title="Seed's nonlinear planar (seed eqs. 4-5)",
    geometry="plane",
    free_force=free_force,
    energy=energy,
    energy_name="E = ½|v|² + ½k²|r|² (not conserved)",
    conserves_energy=False,
    hamiltonian=False,
    refines=("linear",),
)
