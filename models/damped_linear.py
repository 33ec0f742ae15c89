"""The linear planar pendulum with drag: linear (viscous) −γ ṙ and quadratic (air) −c |ṙ| ṙ.

    ẍ = −k² x + 2aẏ − γ ẋ − c s ẋ,   ÿ = −k² y − 2aẋ − γ ẏ − c s ẏ,   s = √(ẋ² + ẏ² + v_s²)

Air drag on a Foucault bob (Reynolds numbers 10⁴-10⁵) is nearly quadratic in the speed, F = ½ ρ C_d S v²
(Landau & Lifshitz, *Fluid Mechanics*, §45); the viscous part (Stokes) and the losses in the wire and the
support are linear in it; a quality factor Q gives γ = k/Q (Landau & Lifshitz, *Mechanics*, §25). The speed s is
smoothed by ``QUADRATIC_DRAG_SPEED_FLOOR_M_S``: |ṙ|ṙ has a discontinuous second derivative at ṙ = 0 (every
release from rest), which would cap every integrator's order at two and give heyoka's Taylor series an
infinite coefficient there; the floor changes the drag force by at most c·v_s·|ṙ|. What the floor leaves is a
force whose complex singularities, on a swing released from rest, lie within ~v_s/|r̈| ≈ 1 ms of every turning
point: a sweep of a high-order method sees pre-asymptotic errors there (the order-8 composition observed 4.9,
Verner's 7(6) main method 2.4), so the order check of ``foucault-bench selftest`` releases this model on an
ellipse with b/a = 0.8 (``order_sweep_ellipse``; the speed then stays within 0.8-1 of kA, its singularities
about 1.1 rad of swing phase off the real axis, and the observed orders are the declared ones).

Frame x South, y East, z Up, a = Ω_E sin φ. E = ½|ṙ|² + ½k²|r|² decays at dE/dt = −(γ + c s)|ṙ|², the work of the
drag (``bench.verdicts.energy_balance``). At γ = c = 0 it is the linear model. The closed form at c = 0 is
``models.analytic.damped_linear_exact`` (models/README.md "Drag and drive").
"""

from foucault_bench.models.base import Model
from foucault_bench.models.jit import jitable
from foucault_bench.models.parameters import (P_DRAG_LINEAR_PER_S, P_DRAG_QUADRATIC_PER_M,  # type: ignore[attr-defined]
                                              P_K2, P_OMEGA_Z)

QUADRATIC_DRAG_SPEED_FLOOR_M_S = 1.0e-3
"""v_s (m/s), the speed below which the quadratic drag turns linear (see the module docstring): 1e-3 of a real
bob's top speed (about 1 m/s for a 3 m swing of a 67 m pendulum)."""


@jitable
def quadratic_drag_rate(m, vx, vy, vz, p):
    """c s (1/s), the quadratic part of the drag rate, with the smoothed speed s."""
    speed = m.sqrt(vx * vx + vy * vy + vz * vz + QUADRATIC_DRAG_SPEED_FLOOR_M_S * QUADRATIC_DRAG_SPEED_FLOOR_M_S)
    return p[P_DRAG_QUADRATIC_PER_M] * speed


@jitable
def drag_rate(m, vx, vy, vz, p):
    """γ + c s (1/s): the drag force per unit mass is −(γ + c s) ṙ."""
    return p[P_DRAG_LINEAR_PER_S] + quadratic_drag_rate(m, vx, vy, vz, p)


def quadratic_drag_watch(m, x, y, vx, vy, p):
    """c s, watched by heyoka's step control (``Model.taylor_step_watch``): s has branch points at
    t* ± i v_s/|r̈| around every turning point t* (2 ms on the Panthéon's pendulum), whose weight c·s in the
    force is too small for the state's own Taylor coefficients to show them (models/README.md "Drag and
    drive"); zero without quadratic drag, where the steps are then those of the unwatched system."""
    return quadratic_drag_rate(m, vx, vy, 0.0, p)


def free_force(m, x, y, z, vx, vy, vz, p):
    """Acceleration (m/s²) of the linear model plus the drag; z and vz are unused (planar model)."""
    k2 = p[P_K2]
    a = p[P_OMEGA_Z]
    rate = drag_rate(m, vx, vy, 0.0 * vz, p)
    return -k2 * x + 2.0 * a * vy - rate * vx, -k2 * y - 2.0 * a * vx - rate * vy, 0.0 * z


def energy(m, x, y, vx, vy, p):
    """E = ½|ṙ|² + ½k²|r|² (J/kg), monitored: it decays by the work of the drag."""
    return 0.5 * (vx * vx + vy * vy) + 0.5 * p[P_K2] * (x * x + y * y)


MODEL = Model(
    name="damped_linear",
    title="Linear planar, linear and quadratic drag",
    geometry="plane",
    free_force=free_force,
    energy=energy,
    energy_name="E = ½|v|² + ½k²|r|² (decays)",
    conserves_energy=False,
    hamiltonian=False,
    refines=("linear",),
    example_parameters={"drag_linear_per_s": 2.0e-3, "drag_quadratic_per_m": 1.0e-3},

    order_sweep_ellipse=0.8,
    adds_parameters=("drag_linear_per_s", "drag_quadratic_per_m"),
    taylor_step_watch=quadratic_drag_watch,
)
