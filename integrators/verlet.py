"""Rotating-frame Störmer–Verlet: Strang splitting of H = [½|p|² + U(r)] + [−ω·(r×p)].

The method and its properties: integrators/README.md "Rotating-frame Verlet".

With the canonical momentum p = ṙ + ω×r the rotating-frame Hamiltonian is
H = ½|p|² − ω·(r×p) + U(r), where −∇U(r) = F(r, 0) + ω×(ω×r) (``Model.numba_kick``). One step is

    R(h/2) ∘ V(h) ∘ R(h/2)

* R(τ): the exact flow of −ω·(r×p), a rotation of r and p about ω by the angle −|ω|τ (Rodrigues' formula);
* V(h): Störmer–Verlet on ½|p|² + U(r): half kick, drift, half kick; on the sphere this is RATTLE, which
  keeps |r| = L and r·p = 0 to round-off (Andersen, J. Comput. Phys. 52, 24, 1983;
  Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed., §VII.1.4).

Both parts are symplectic and the composition is symmetric, so the method is symplectic and of order 2
(Hairer, Lubich & Wanner §II.5 and §VI.3); ``tests/test_verlet.py`` checks the symplectic identity of its
one-step Jacobian and the observed order. On the isotropic linear model the two parts commute, so the
precession is exact to round-off and only the swing frequency carries the Verlet error (kh)²/24.
Stable for kh < 2 (the Verlet limit on ½|p|² + ½(k² + a²)|r|²). The naive velocity Verlet with an explicit
Coriolis kick is not used: it is neither symplectic nor volume-preserving and opens the swing into an
ellipse (integrators/README.md "Rotating-frame Verlet").

Uses from the model: ``numba_kick`` (the position-only force), ``coriolis_vector`` (ω_c: the vertical part
in the planar models, the full ω on the sphere) and the geometry (sphere → RATTLE). For a model that is not
Hamiltonian (the seed's eqs. 4-5) the remaining velocity-dependent force G(r, ṙ) (``numba_remainder``) is
added to both half kicks, explicitly in the first and implicitly (two fixed-point sweeps) in the second: the
kick–drift–kick part is then the composition of a first-order map with its adjoint, symmetric and of order 2,
but no longer symplectic (that model has no symplectic structure to keep). 2 force evaluations per step
(the first kick of a step cannot reuse the last kick of the previous one because R(h/2) turns r in between).
"""

import math
from typing import Callable, ClassVar

from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.registry import register
from foucault_bench.models import Model
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import P_LENGTH, P_OMEGA_X, P_OMEGA_Y, P_OMEGA_Z


@register
class RotatingVerlet(FixedStepIntegrator):
    name: ClassVar[str] = "verlet"
    family: ClassVar[str] = "verlet"
    order: ClassVar[int] = 2
    stages: ClassVar[int] = 2
    stability_limit_kh: ClassVar[float] = 2.0
    symplectic: ClassVar[bool] = True
    reference: ClassVar[str] = (
        "Störmer-Verlet + exact rotation (Strang splitting), RATTLE on the sphere; Hairer, Lubich & Wanner, "
        "Geometric Numerical Integration, 2nd ed., §I.3, §II.5, §VII.1.4"
    )

    def make_step(self, model: Model) -> Callable:
        kick = model.numba_kick
        if model.constrained_to_sphere:
            if not model.hamiltonian:
                raise NotImplementedError("RATTLE with a non-Coriolis velocity force is not implemented")
            return _sphere_step(kick)
        return _plane_step(kick, model.numba_remainder, model.hamiltonian)


def _plane_step(kick: Callable, remainder: Callable, hamiltonian: bool) -> Callable:
    @jit
    def step(x, y, vx, vy, h, p):
        a = p[P_OMEGA_Z]
        cos_half = math.cos(-0.5 * a * h)
        sin_half = math.sin(-0.5 * a * h)
        # canonical momentum p = v + ω_c×r, ω_c = a ẑ
        px = vx - a * y
        py = vy + a * x
        # R(h/2): rotate r and p by −a h/2 about z
        x, y = cos_half * x - sin_half * y, sin_half * x + cos_half * y
        px, py = cos_half * px - sin_half * py, sin_half * px + cos_half * py
        # V(h): kick, drift, kick
        fx, fy, _ = kick(x, y, 0.0, p)
        if not hamiltonian:
            gx, gy, _ = remainder(x, y, 0.0, px + a * y, py - a * x, 0.0, p)
            fx += gx
            fy += gy
        px += 0.5 * h * fx
        py += 0.5 * h * fy
        x += h * px
        y += h * py
        fx, fy, _ = kick(x, y, 0.0, p)
        px_half = px
        py_half = py
        px = px_half + 0.5 * h * fx
        py = py_half + 0.5 * h * fy
        if not hamiltonian:
            for _sweep in range(2):
                gx, gy, _ = remainder(x, y, 0.0, px + a * y, py - a * x, 0.0, p)
                px = px_half + 0.5 * h * (fx + gx)
                py = py_half + 0.5 * h * (fy + gy)
        # R(h/2)
        x, y = cos_half * x - sin_half * y, sin_half * x + cos_half * y
        px, py = cos_half * px - sin_half * py, sin_half * px + cos_half * py
        return x, y, px + a * y, py - a * x

    return step


def _sphere_step(kick: Callable) -> Callable:
    # Inlined into the fixed-step loop (too large for LLVM's own inliner), so that the rotation matrix, which
    # depends only on p and h, is computed once per run (hoisted out of the loop) instead of once per call.
    @jit(inline="always")
    def step(x, y, vx, vy, h, p):
        wx = p[P_OMEGA_X]
        wy = p[P_OMEGA_Y]
        wz = p[P_OMEGA_Z]
        length = p[P_LENGTH]
        l2 = length * length
        rotation = _half_step_rotation(wx, wy, wz, h)
        z = -math.sqrt(l2 - x * x - y * y)
        vz = -(x * vx + y * vy) / z
        # canonical momentum p = v + ω×r
        px = vx + wy * z - wz * y
        py = vy + wz * x - wx * z
        pz = vz + wx * y - wy * x
        x, y, z = _rotate(rotation, x, y, z)
        px, py, pz = _rotate(rotation, px, py, pz)
        # RATTLE on ½|p|² + U(r), |r| = L
        fx, fy, fz = kick(x, y, z, p)
        qx = x + h * (px + 0.5 * h * fx)
        qy = y + h * (py + 0.5 * h * fy)
        qz = z + h * (pz + 0.5 * h * fz)
        qr = qx * x + qy * y + qz * z
        excess = qx * qx + qy * qy + qz * qz - l2
        c = -excess / (qr + math.sqrt(qr * qr - l2 * excess))  # root of |q + c r|² = L² nearest 0
        xn = qx + c * x
        yn = qy + c * y
        zn = qz + c * z
        px = (xn - x) / h
        py = (yn - y) / h
        pz = (zn - z) / h
        fx, fy, fz = kick(xn, yn, zn, p)
        px += 0.5 * h * fx
        py += 0.5 * h * fy
        pz += 0.5 * h * fz
        nu = -(xn * px + yn * py + zn * pz) / l2  # keeps r·p = 0 (hidden constraint)
        px += nu * xn
        py += nu * yn
        pz += nu * zn
        xn, yn, zn = _rotate(rotation, xn, yn, zn)
        px, py, pz = _rotate(rotation, px, py, pz)
        return xn, yn, px - (wy * zn - wz * yn), py - (wz * xn - wx * zn)

    return step


@jit
def _half_step_rotation(wx, wy, wz, h):
    """The rotation about ω = (wx, wy, wz) by the angle −|ω| h/2 as a 3×3 matrix (row-major 9-tuple):
    R = cos a·I + sin a·[n]× + (1 − cos a)·n nᵀ, n = ω/|ω| (Rodrigues' rotation formula in matrix form,
    e.g. Goldstein, Classical Mechanics, 3rd ed., §4.7); the identity when ω = 0. Computed once per run,
    R applies in 9 multiplications and 6 additions instead of Rodrigues' vector form's 18 and 12."""
    rate = math.sqrt(wx * wx + wy * wy + wz * wz)
    if rate == 0.0:
        return 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    nx = wx / rate
    ny = wy / rate
    nz = wz / rate
    angle = -0.5 * rate * h
    cos_a = math.cos(angle)
    sin_a = math.sin(angle)
    u = 1.0 - cos_a
    return (
        cos_a + u * nx * nx, u * nx * ny - sin_a * nz, u * nx * nz + sin_a * ny,
        u * ny * nx + sin_a * nz, cos_a + u * ny * ny, u * ny * nz - sin_a * nx,
        u * nz * nx - sin_a * ny, u * nz * ny + sin_a * nx, cos_a + u * nz * nz,
    )


@jit
def _rotate(rotation, vx, vy, vz):
    """R·(vx, vy, vz) for a row-major 3×3 matrix R (``_half_step_rotation``)."""
    return (
        rotation[0] * vx + rotation[1] * vy + rotation[2] * vz,
        rotation[3] * vx + rotation[4] * vy + rotation[5] * vz,
        rotation[6] * vx + rotation[7] * vy + rotation[8] * vz,
    )
