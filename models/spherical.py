"""Model 3: the spherical pendulum in the rotating frame with the full rotation vector (the physical model).

Bob at r = (x, y, z) from the pivot, |r| = L, frame x South, y East, z Up, ω = Ω_E(−cos φ, 0, sin φ):

    r̈ = F + μ r,   F = −g ẑ − 2 ω×ṙ − c·ω×(ω×r),   μ = −(|ṙ|² + r·F) / L²

c = 1 keeps the centrifugal force, c = 0 drops it. The state is (x, y, ẋ, ẏ) with z = −√(L² − x² − y²) and
ż = −(xẋ + yẏ)/z, regular through the vertical. The Jacobi integral

    h = ½|ṙ|² + g z − (c/2)|ω×r|²

is conserved exactly. Source: models/README.md "Spherical model" (d'Alembert's principle for a particle on a sphere in a
rotating frame; e.g. Goldstein, Classical Mechanics, 3rd ed., §4.10 for the fictitious forces).
"""

from foucault_bench.models.base import Model, sphere_height
from foucault_bench.models.parameters import P_CENTRIFUGAL, P_GRAVITY, P_OMEGA_X, P_OMEGA_Y, P_OMEGA_Z


def free_force(m, x, y, z, vx, vy, vz, p):
    """F = −g ẑ − 2ω×ṙ − c·ω×(ω×r) (m/s²), the force per unit mass before the string's constraint."""
    wx = p[P_OMEGA_X]
    wy = p[P_OMEGA_Y]
    wz = p[P_OMEGA_Z]
    c = p[P_CENTRIFUGAL]
    # ω×r and ω×ṙ
    wrx = wy * z - wz * y
    wry = wz * x - wx * z
    wrz = wx * y - wy * x
    wvx = wy * vz - wz * vy
    wvy = wz * vx - wx * vz
    wvz = wx * vy - wy * vx
    # ω×(ω×r)
    cx = wy * wrz - wz * wry
    cy = wz * wrx - wx * wrz
    cz = wx * wry - wy * wrx
    return -2.0 * wvx - c * cx, -2.0 * wvy - c * cy, -p[P_GRAVITY] - 2.0 * wvz - c * cz


def energy(m, x, y, vx, vy, p):
    """Jacobi integral h = ½|ṙ|² + g z − (c/2)|ω×r|² (J/kg), conserved exactly (models/README.md "Energy and the
    Jacobi integral")."""
    z, vz = sphere_height(m, x, y, vx, vy, p)
    wx = p[P_OMEGA_X]
    wy = p[P_OMEGA_Y]
    wz = p[P_OMEGA_Z]
    wrx = wy * z - wz * y
    wry = wz * x - wx * z
    wrz = wx * y - wy * x
    kinetic = 0.5 * (vx * vx + vy * vy + vz * vz)
    return kinetic + p[P_GRAVITY] * z - 0.5 * p[P_CENTRIFUGAL] * (wrx * wrx + wry * wry + wrz * wrz)


MODEL = Model(
    name="spherical",
    title="Spherical pendulum, rotating frame, full ω",
    geometry="sphere",
    free_force=free_force,
    energy=energy,
    energy_name="Jacobi h = ½|ṙ|² + gz − (c/2)|ω×r|²",
    conserves_energy=True,
    hamiltonian=True,
    refines=("seed_planar",),
)
