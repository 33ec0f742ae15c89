"""The linear planar pendulum on an anisotropic support: small-swing frequencies k(1 ± ε/2) along and across an
axis at azimuth β (the main source of false precession in real Foucault pendulums).

A support (wire clamp, suspension) that is slightly stiffer in one horizontal direction splits the two swing
frequencies; a swing that is not along a principal axis then opens into an ellipse and its plane turns by
itself (Schumacher & Tarbet, arXiv:0902.1829 (2009); Salva & Salva, arXiv:2502.12230 (2025), who characterise
a support by the difference of the periods along its principal axes). With e = (cos β, sin β) the stiff axis
(frequency k(1 + ε/2)) and e⊥ the soft one (k(1 − ε/2)), the restoring force per unit mass is −K r with

    K = k² [(1 + ε/2)² e eᵀ + (1 − ε/2)² e⊥ e⊥ᵀ] = k² [(1 + ε²/4) I + ε R(2β)],
    R(2β) = [[cos 2β, sin 2β], [sin 2β, −cos 2β]]

(R(2β) e = e, R(2β) e⊥ = −e⊥), so that

    ẍ = −k² x − k² [(ε²/4) x + ε (cos 2β x + sin 2β y)] + 2aẏ
    ÿ = −k² y − k² [(ε²/4) y + ε (sin 2β x − cos 2β y)] − 2aẋ,      a = Ω_E sin φ.

Frame x South, y East, z Up; β from South towards East. The Coriolis force does no work and the support force
has the potential ½ r·(K − k²I) r, so E = ½|ṙ|² + ½ r·K r is conserved exactly and the model is Hamiltonian.
At ε = 0 it is the linear model. Its precession rate is in ``models.analytic.anisotropic_precession_rate_rad_s``
(models/README.md "Anisotropic support").
"""

from foucault_bench.models.base import Model
from foucault_bench.models.jit import jitable
from foucault_bench.models.parameters import (P_ANISOTROPY_AXIS_DEG, P_K2, P_OMEGA_Z,  # type: ignore[attr-defined]
                                              P_SUPPORT_ANISOTROPY)

DEGREES_TO_DOUBLE_ANGLE_RAD = 3.141592653589793 / 90.0
"""2β in radians per degree of β."""


@jitable
def support_force(m, x, y, p):
    """The horizontal force (m/s²) the support's anisotropy adds to −k² r: −k²[(ε²/4) r + ε R(2β) r]."""
    k2 = p[P_K2]
    epsilon = p[P_SUPPORT_ANISOTROPY]
    double_axis = p[P_ANISOTROPY_AXIS_DEG] * DEGREES_TO_DOUBLE_ANGLE_RAD
    c2 = m.cos(double_axis)
    s2 = m.sin(double_axis)
    isotropic = 0.25 * epsilon * epsilon
    return (-k2 * (isotropic * x + epsilon * (c2 * x + s2 * y)),
            -k2 * (isotropic * y + epsilon * (s2 * x - c2 * y)))


@jitable
def support_potential(m, x, y, p):
    """The potential (J/kg) of ``support_force``: ½k²[(ε²/4)|r|² + ε r·R(2β) r]."""
    epsilon = p[P_SUPPORT_ANISOTROPY]
    double_axis = p[P_ANISOTROPY_AXIS_DEG] * DEGREES_TO_DOUBLE_ANGLE_RAD
    c2 = m.cos(double_axis)
    s2 = m.sin(double_axis)
    quadratic = c2 * (x * x - y * y) + 2.0 * s2 * x * y
    return 0.5 * p[P_K2] * (0.25 * epsilon * epsilon * (x * x + y * y) + epsilon * quadratic)


def free_force(m, x, y, z, vx, vy, vz, p):
    """Acceleration (m/s²) of the linear model plus ``support_force``; z and vz are unused (planar model)."""
    k2 = p[P_K2]
    a = p[P_OMEGA_Z]
    sx, sy = support_force(m, x, y, p)
    return -k2 * x + sx + 2.0 * a * vy, -k2 * y + sy - 2.0 * a * vx, 0.0 * z


def energy(m, x, y, vx, vy, p):
    """E = ½|ṙ|² + ½ r·K r per unit mass (J/kg), conserved exactly."""
    return 0.5 * (vx * vx + vy * vy) + 0.5 * p[P_K2] * (x * x + y * y) + support_potential(m, x, y, p)


MODEL = Model(
    name="anisotropic_linear",
    title="Linear planar, anisotropic support k(1 ± ε/2)",
    geometry="plane",
    free_force=free_force,
    energy=energy,
    energy_name="E = ½|v|² + ½ r·K r",
    conserves_energy=True,
    hamiltonian=True,
    refines=("linear",),
    example_parameters={"support_anisotropy": 0.02, "anisotropy_axis_deg": 30.0},
    adds_parameters=("support_anisotropy",),
)
