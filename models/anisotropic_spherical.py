"""The spherical pendulum (``models.spherical``) on an anisotropic support: the horizontal support force of
``models.anisotropic_linear`` added to the force before the string's constraint.

    F = −g ẑ − 2ω×ṙ − c·ω×(ω×r) − k² [(ε²/4) r_h + ε R(2β) r_h],     r_h = (x, y, 0)

so that the small-swing frequencies are k(1 ± ε/2) along and across the axis at azimuth β, as on the linear
model; the finite swing adds Airy's precession (models/README.md "Airy precession"). The added force is
horizontal with the potential ½k²[(ε²/4)|r_h|² + ε r_h·R(2β) r_h], so the Jacobi integral plus that potential
is conserved exactly and the model is Hamiltonian. At ε = 0 it is the spherical model. Salva & Salva
(arXiv:2502.12230, 2025) study this interplay of support anisotropy and Airy precession on a 4.8 m pendulum.
"""

from foucault_bench.models import spherical
from foucault_bench.models.anisotropic_linear import support_force, support_potential
from foucault_bench.models.base import Model
from foucault_bench.models.jit import jitable

spherical_force = jitable(spherical.free_force)
"""The spherical model's force source, compiled into this one's (a source calls only jitable helpers)."""
spherical_energy = jitable(spherical.energy)


def free_force(m, x, y, z, vx, vy, vz, p):
    """The spherical model's force (m/s²) plus the horizontal support force."""
    fx, fy, fz = spherical_force(m, x, y, z, vx, vy, vz, p)
    sx, sy = support_force(m, x, y, p)
    return fx + sx, fy + sy, fz


def energy(m, x, y, vx, vy, p):
    """Jacobi integral plus the support's potential (J/kg), conserved exactly."""
    return spherical_energy(m, x, y, vx, vy, p) + support_potential(m, x, y, p)


MODEL = Model(
    name="anisotropic_spherical",
    title="Spherical pendulum, full ω, anisotropic support k(1 ± ε/2)",
    geometry="sphere",
    free_force=free_force,
    energy=energy,
    energy_name="h + ½k²[(ε²/4)|r_h|² + ε r_h·R(2β) r_h]",
    conserves_energy=True,
    hamiltonian=True,
    refines=("spherical",),
    example_parameters={"support_anisotropy": 0.02, "anisotropy_axis_deg": 30.0},
    adds_parameters=("support_anisotropy",),
)
