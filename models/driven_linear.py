"""The damped linear pendulum (``models.damped_linear``) kept swinging by a drive near the centre.

Museum pendulums are driven by an electromagnet under the centre of the swing that pushes the bob's magnet
as it passes, in phase with the swing (University of Guelph, "The Foucault Pendulum", B. Nickel, after
H. R. Crane's design: a drive coil under the bob triggered by a sense coil, physics.uoguelph.ca/foucault/F14.html;
Ellinogermaniki Agogi, Athens: an electromagnet at the centre of the disk, ea.gr). The push acts along the
velocity, only near the centre, and pumps energy without turning the swing plane. A smooth model of it:

    f_drive = κ ṙ / (1 + |r|²/r_d²)

(a Lorentzian profile of width r_d: the pulse of a real coil has no sharp edges either, and a smooth force keeps
every integrator's order; but on a planar swing through the centre the profile's poles, at |r| = i r_d, lie
only asinh(r_d/A) ≈ 0.17 rad of swing phase off the real time axis, so the order check of ``foucault-bench
selftest`` releases this model on an ellipse with b/a = 0.8, ``order_sweep_ellipse``, which keeps the bob at
0.8 A or more from the centre and the poles about 1.1 rad away). The power κ|ṙ|²/(1 + |r|²/r_d²) balances the drag's (γ + c s)|ṙ|² at one amplitude,
the swing's limit cycle. At κ = 0 it is the damped model.
"""

from foucault_bench.models import damped_linear
from foucault_bench.models.base import Model
from foucault_bench.models.jit import jitable
from foucault_bench.models.parameters import P_DRIVE_GAIN_PER_S, P_DRIVE_RADIUS_M  # type: ignore[attr-defined]

damped_force = jitable(damped_linear.free_force)
"""The damped model's force source, compiled into this one's (a source calls only jitable helpers)."""


@jitable
def drive_rate(m, x, y, p):
    """κ / (1 + |r|²/r_d²) (1/s): the drive force per unit mass is this times ṙ."""
    radius = p[P_DRIVE_RADIUS_M]
    return p[P_DRIVE_GAIN_PER_S] / (1.0 + (x * x + y * y) / (radius * radius))


def free_force(m, x, y, z, vx, vy, vz, p):
    """The damped model's acceleration (m/s²) plus the drive."""
    fx, fy, fz = damped_force(m, x, y, z, vx, vy, vz, p)
    rate = drive_rate(m, x, y, p)
    return fx + rate * vx, fy + rate * vy, fz


MODEL = Model(
    name="driven_linear",
    title="Linear planar, drag and a drive near the centre",
    geometry="plane",
    free_force=free_force,
    energy=damped_linear.energy,
    energy_name="E = ½|v|² + ½k²|r|² (drag and drive)",
    conserves_energy=False,
    hamiltonian=False,
    refines=("damped_linear",),
    example_parameters={"drive_gain_per_s": 3.0e-3, "drive_radius_m": 0.05},

    order_sweep_ellipse=0.8,
    adds_parameters=("drive_gain_per_s",),
    taylor_step_watch=damped_linear.quadratic_drag_watch,
)
