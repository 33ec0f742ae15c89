"""Boris-type Coriolis integrator: drift, half kick, exact rotation of the velocity, half kick, drift.

The Coriolis acceleration −2ω×v rotates the velocity without changing its length, exactly as a magnetic field
turns a charged particle; Boris's scheme treats it that way (Boris, Proc. 4th Conf. Num. Sim. Plasmas, 1970;
Qin et al., Phys. Plasmas 20, 084503 (2013)). One step is the symmetric splitting

    D(h/2) ∘ K(h/2) ∘ C(h) ∘ K(h/2) ∘ D(h/2)

of ẍ = F(r) − 2ω×ṙ into exact flows: D the drift ṙ = v, K the kick v̇ = F(r) by the position-only force
(gravity, and the centrifugal term where the model has it), C the Coriolis rotation v̇ = −2ω×v, v turned by
the angle −2|ω|h about ω. Each flow preserves phase-space volume and the composition is symmetric, so the
method is volume-preserving, time-reversible and of order 2 (Hairer, Lubich & Wanner, Geometric Numerical
Integration, 2nd ed., §II.5 and §VI.9); it is not symplectic for the rotating frame's Hamiltonian in general.
One force evaluation per step (the two half kicks act at the same position). In staggered form (positions at
half steps) it is Boris's pusher: half kick, rotation, half kick. Stable for kh < 2 on the oscillator (position
Verlet's limit; the rotation is an isometry of the velocity).

**Planar models** (linear, the seed's eqs.): the Coriolis vector is the vertical a ẑ, the rotation turns
(ẋ, ẏ) clockwise by 2ah. A velocity-dependent force that is not Coriolis (the seed's eqs. 4-5, ``Model.numba_remainder``)
is added to the half kicks, explicitly in the first and implicitly (two fixed-point sweeps) in the second, as in
``integrators.methods.verlet``.

**Sphere**: every flow is constrained to |r| = L. The drift is the exact geodesic flow (a great circle at
constant speed); the kick adds the tangential part of F(r); the rotation turns v about the local vertical
n̂ = r/L by −2(ω·n̂)h (the tangential part of −2ω×v for a tangential v; the normal part is taken up by the
string). The three constrained flows add up to the constrained equations of motion (the normal forces,
centripetal included, are the constraint's), so the splitting is consistent.
"""

import math
from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.registry import register
from foucault_bench.models import Model
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import P_LENGTH, P_OMEGA_X, P_OMEGA_Y, P_OMEGA_Z


@register
class Boris(FixedStepIntegrator):
    name: ClassVar[str] = "boris"
    family: ClassVar[str] = "boris"
    order: ClassVar[int] = 2
    stages: ClassVar[int] = 1
    stability_limit_kh: ClassVar[float] = 2.0
    volume_preserving: ClassVar[bool] = True
    reference: ClassVar[str] = (
        "Boris (1970); Qin et al., Phys. Plasmas 20, 084503 (2013); Hairer, Lubich & Wanner, Geometric "
        "Numerical Integration, 2nd ed., §II.5"
    )

    def make_step(self, model: Model) -> Callable:
        if model.constrained_to_sphere:
            if not model.hamiltonian:
                raise NotImplementedError("the constrained Boris step with a non-Coriolis velocity force")
            return _sphere_step(model.numba_free_force)
        return _plane_step(model.numba_free_force, model.numba_remainder, model.hamiltonian)


def _plane_step(force: Callable, remainder: Callable, hamiltonian: bool) -> Callable:
    @jit
    def step(x, y, vx, vy, h, p):
        half = 0.5 * h
        angle = -2.0 * p[P_OMEGA_Z] * h  # Coriolis turns v about ẑ at the rate −2a
        cos_a = math.cos(angle)
        sin_a = math.sin(angle)
        x += half * vx
        y += half * vy
        fx, fy, _ = force(math, x, y, 0.0, 0.0, 0.0, 0.0, p)
        if not hamiltonian:
            gx, gy, _ = remainder(x, y, 0.0, vx, vy, 0.0, p)
            vx += half * (fx + gx)
            vy += half * (fy + gy)
        else:
            vx += half * fx
            vy += half * fy
        vx, vy = cos_a * vx - sin_a * vy, sin_a * vx + cos_a * vy
        turned_x = vx
        turned_y = vy
        vx = turned_x + half * fx
        vy = turned_y + half * fy
        if not hamiltonian:
            for _sweep in range(2):
                gx, gy, _ = remainder(x, y, 0.0, vx, vy, 0.0, p)
                vx = turned_x + half * (fx + gx)
                vy = turned_y + half * (fy + gy)
        return x + half * vx, y + half * vy, vx, vy

    return step


def _sphere_step(force: Callable) -> Callable:
    @jit
    def step(x, y, vx, vy, h, p):
        half = 0.5 * h
        length = p[P_LENGTH]
        wx = p[P_OMEGA_X]
        wy = p[P_OMEGA_Y]
        wz = p[P_OMEGA_Z]
        z = -math.sqrt(length * length - x * x - y * y)
        vz = -(x * vx + y * vy) / z
        x, y, z, vx, vy, vz = _geodesic(x, y, z, vx, vy, vz, length, half)
        fx, fy, fz = force(math, x, y, z, 0.0, 0.0, 0.0, p)
        radial = (fx * x + fy * y + fz * z) / (length * length)
        fx -= radial * x
        fy -= radial * y
        fz -= radial * z
        vx += half * fx
        vy += half * fy
        vz += half * fz
        # rotate v about n = r/L by the angle −2(ω·n)h: v cos α + (n×v) sin α (v ⟂ n)
        nx = x / length
        ny = y / length
        nz = z / length
        angle = -2.0 * (wx * nx + wy * ny + wz * nz) * h
        cos_a = math.cos(angle)
        sin_a = math.sin(angle)
        vx, vy, vz = (
            cos_a * vx + sin_a * (ny * vz - nz * vy),
            cos_a * vy + sin_a * (nz * vx - nx * vz),
            cos_a * vz + sin_a * (nx * vy - ny * vx),
        )
        vx += half * fx
        vy += half * fy
        vz += half * fz
        x, y, z, vx, vy, vz = _geodesic(x, y, z, vx, vy, vz, length, half)
        return x, y, vx, vy

    return step


@jit
def _geodesic(x, y, z, vx, vy, vz, length, tau):
    """Exact free motion on the sphere |r| = L for a time τ: a great circle at constant speed s = |v|, r and v
    turned by the angle sτ/L in the plane they span (v ⟂ r)."""
    speed = math.sqrt(vx * vx + vy * vy + vz * vz)
    if speed == 0.0:
        return x, y, z, vx, vy, vz
    angle = speed * tau / length
    cos_a = math.cos(angle)
    sin_a = math.sin(angle)
    along = length / speed * sin_a  # r(τ) = r cos θ + (L/s) v sin θ
    back = -speed / length * sin_a  # v(τ) = −(s/L) r sin θ + v cos θ
    return (
        x * cos_a + vx * along,
        y * cos_a + vy * along,
        z * cos_a + vz * along,
        x * back + vx * cos_a,
        y * back + vy * cos_a,
        z * back + vz * cos_a,
    )
