"""Rotating-frame Störmer–Verlet: Strang splitting of H = [½|p|² + U(r)] + [−ω·(r×p)].

The method and its properties: integrators/README.md "Rotating-frame Verlet".

With the canonical momentum p = ṙ + ω×r the rotating-frame Hamiltonian is
H = ½|p|² − ω·(r×p) + U(r), where −∇U(r) = F(r, 0) + ω×(ω×r) (``Model.numba_kick``). One step is

    R(h/2) ∘ V(h) ∘ R(h/2)

* R(τ): the exact flow of −ω·(r×p), a rotation of r and p about ω by the angle −|ω|τ (Rodrigues' formula; on the
  plane as three shears, t = tan(a/2), s = sin a: Paeth, Graphics Gems (1990), "A fast algorithm for general raster
  rotation", applied to r, with their inverse transposes applied to p, so that the rounded turn is still exactly
  symplectic and the invariants do not drift by ε a turn, bench/PERF.md "Round-off");
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

Uses from the model: ``numba_kick`` (the position-only force) and the geometry (sphere → RATTLE: the rotation
ω_c is the full ω, read from p[P_OMEGA_X..Z]; plane: ω_c is its vertical part p[P_OMEGA_Z]). For a model that is not
Hamiltonian (the seed's eqs. 4-5) the remaining velocity-dependent force G(r, ṙ) (``numba_remainder``) is
added to both half kicks, explicitly in the first and implicitly (two fixed-point sweeps) in the second: the
kick–drift–kick part is then the composition of a first-order map with its adjoint, symmetric and of order 2,
but no longer symplectic (that model has no symplectic structure to keep). 2 force evaluations per step
(the first kick of a step cannot reuse the last kick of the previous one because R(h/2) turns r in between).

``verlet_sequences`` builds the step for a sequence of sub-steps γ_1 h … γ_s h (the compositions of
``integrators.composition``; one Verlet step is γ = (1,)): the state stays in the canonical variables from the
first sub-step to the last, and the two half rotations between neighbouring sub-steps are one rotation (both
turn about ω_c, so their angles add). That is the same map as s separate Verlet steps, with s − 1 fewer
rotations and variable changes. The rotations and sub-step sizes depend on p and h alone: a setup computes them
once per run into a small table, and the step is one compiled sub-step body in a loop over that table, so a
35-sub-step composition compiles in the time of one sub-step (bench/PERF.md "The compositions' compile time").
"""

import math
from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np
from numba.np.unsafe.ndarray import to_fixed_tuple

from foucault_bench.integrators.fixed_step import FixedStepIntegrator, with_setup
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
        "Geometric Numerical Integration, 2nd ed., §I.1.4, §II.5, §VII.1.4, and Acta Numerica 12, 399 (2003)"
    )

    def make_step(self, model: Model) -> Callable:
        return with_setup(*self.make_setup_step(model))

    def make_setup_step(self, model: Model) -> tuple[Callable, Callable]:
        return verlet_sequences(model, (1.0,), 1)


@dataclass(frozen=True)
class _Parts:
    """The pieces of a rotating-frame Verlet step on one geometry, each a numba function of the canonical state
    q = (r, p) as a tuple: (x, y, px, py) on the plane, (x, y, z, px, py, pz) on the sphere."""

    to_canonical: Callable  # (x, y, vx, vy, p) -> q
    rotation: Callable  # (c, h, p) -> R(c h): the turn about ω_c by the angle −|ω_c| c h, as a tuple of floats
    rotation_size: int  # the length of that tuple
    turn: Callable  # (R, q) -> R q: r and p turned
    kick_drift_kick: Callable  # (q, h, p) -> V(h) q
    from_canonical: Callable  # (q, p) -> (x, y, vx, vy)


def rotation_coefficients(weights: tuple[float, ...]) -> tuple[float, ...]:
    """c_0 … c_s of R(c_s h) ∘ V(γ_s h) ∘ … ∘ R(c_1 h) ∘ V(γ_1 h) ∘ R(c_0 h): the half rotations of two
    neighbouring sub-steps merged (rotations about one axis add), c_0 = γ_1/2, c_i = (γ_i + γ_(i+1))/2,
    c_s = γ_s/2."""
    inner = [0.5 * (a + b) for a, b in zip(weights[:-1], weights[1:], strict=True)]
    return (0.5 * weights[0], *inner, 0.5 * weights[-1])


def verlet_sequences(model: Model, weights: tuple[float, ...], sequence_sub_steps: int,
                     remainder_sweeps: int = 2) -> tuple[Callable, Callable]:
    """``(setup, step)`` of the rotating-frame Verlet steps with sub-steps γ_1 h … γ_s h in turn (one Verlet step:
    ``weights = (1.0,)``), taken as consecutive sequences of ``sequence_sub_steps`` sub-steps (the last one
    shorter). Each sequence is computed in the canonical variables with neighbouring rotations merged
    (``rotation_coefficients`` of its weights); between sequences the state returns to (x, y, vx, vy).
    ``remainder_sweeps``: the fixed-point sweeps of the implicit half kick on a model with a velocity-dependent
    remainder (``_plane_parts``).

    ``setup(h, p)`` computes what depends on p and h alone, once per run (the fixed-step loop calls it before
    its first step, ``integrators.fixed_step.build_kernel``): ``(p, turns, sub_h)`` with ``turns`` the rotations of
    every sequence in order (row j·(L + 1) + i: R(c_i h) of sequence j, one rotation per row, as a tuple of
    floats, ``_Parts.rotation``) and ``sub_h`` the sub-step sizes γ_i h. ``step(x, y, vx, vy, h, constants)``
    takes them in place of p: one compiled sub-step body in a loop over the table's rows, however many sub-steps
    the composition has (compile time does not grow with s), doing the arithmetic of the sub-steps written out
    one by one, in the same order, on the same numbers (bitwise the same states)."""
    parts = verlet_parts(model, remainder_sweeps)
    weights = tuple(float(gamma) for gamma in weights)
    sequences = [weights[first:first + sequence_sub_steps] for first in range(0, len(weights), sequence_sub_steps)]
    coefficients = tuple(c for sequence in sequences for c in rotation_coefficients(sequence))
    rotation, rotation_size = parts.rotation, parts.rotation_size
    to_canonical, turn, kick_drift_kick, from_canonical = (
        parts.to_canonical, parts.turn, parts.kick_drift_kick, parts.from_canonical)
    sub_steps, sequence_count, rotation_count = len(weights), len(sequences), len(coefficients)

    @jit
    def setup(h, p):
        turns = np.empty((rotation_count, rotation_size))
        for row in range(rotation_count):
            turn_row = rotation(coefficients[row], h, p)
            for entry in range(rotation_size):  # element by element: a slice assignment takes seconds to compile
                turns[row, entry] = turn_row[entry]
        sub_h = np.empty(sub_steps)
        for i in range(sub_steps):
            sub_h[i] = weights[i] * h
        return p, turns, sub_h

    @jit(inline="always")
    def step(x, y, vx, vy, h, constants):
        p, turns, sub_h = constants
        for sequence in range(sequence_count):
            first = sequence * sequence_sub_steps
            last = min(first + sequence_sub_steps, sub_steps)
            q = to_canonical(x, y, vx, vy, p)
            for i in range(first, last):  # sub-step i turns by row i + sequence, the sequence's rows being shifted by its closing one
                q = kick_drift_kick(turn(to_fixed_tuple(turns[i + sequence], rotation_size), q), sub_h[i], p)
            x, y, vx, vy = from_canonical(turn(to_fixed_tuple(turns[last + sequence], rotation_size), q), p)
        return x, y, vx, vy

    return setup, step


def verlet_parts(model: Model, remainder_sweeps: int = 2) -> _Parts:
    """The pieces of the rotating-frame Verlet step on the model's geometry (RATTLE on the sphere)."""
    return _sphere_parts(model) if model.constrained_to_sphere else _plane_parts(model, remainder_sweeps)


def _plane_parts(model: Model, remainder_sweeps: int = 2) -> _Parts:
    """The planar pieces: ω_c = a ẑ, p = v + a ẑ×r; the model's velocity-dependent remainder (if any) added to the
    half kicks, explicitly in the first and implicitly (``remainder_sweeps`` fixed-point sweeps) in the second.
    Each sweep multiplies the error of the implicit solve by O(h ∂G/∂v); two make the step symmetric to well
    beyond order 2, a composition of order p needs its base step symmetric beyond order p (more sweeps)."""
    kick, remainder, hamiltonian = model.numba_kick, model.numba_remainder, model.hamiltonian

    @jit(inline="always")
    def to_canonical(x, y, vx, vy, p):
        a = p[P_OMEGA_Z]
        return x, y, vx - a * y, vy + a * x

    @jit(inline="always")
    def rotation(c, h, p):
        angle = -c * p[P_OMEGA_Z] * h
        return math.tan(0.5 * angle), math.sin(angle)

    @jit(inline="always")
    def turn(rotation, q):
        # the turn as three shears (Paeth 1986): r by S(t)·T(s)·S(t), p by their inverse transposes (the cotangent
        # lift), so that the map is symplectic for the rounded t and s too; cos a and sin a rounded give
        # cos² + sin² = 1 + O(ε), a drift of every invariant by O(ε) each turn (bench/PERF.md "Round-off")
        t, s = rotation
        x, y, px, py = q
        x -= t * y
        py += t * px
        y += s * x
        px -= s * py
        x -= t * y
        py += t * px
        return x, y, px, py

    @jit(inline="always")
    def kick_drift_kick(q, h, p):
        x, y, px, py = q
        a = p[P_OMEGA_Z]
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
            for _sweep in range(remainder_sweeps):
                gx, gy, _ = remainder(x, y, 0.0, px + a * y, py - a * x, 0.0, p)
                px = px_half + 0.5 * h * (fx + gx)
                py = py_half + 0.5 * h * (fy + gy)
        return x, y, px, py

    @jit(inline="always")
    def from_canonical(q, p):
        x, y, px, py = q
        a = p[P_OMEGA_Z]
        return x, y, px + a * y, py - a * x

    return _Parts(to_canonical, rotation, 2, turn, kick_drift_kick, from_canonical)


def _sphere_parts(model: Model) -> _Parts:
    """The spherical pieces: full ω, p = v + ω×r, RATTLE for the kick–drift–kick on |r| = L."""
    if not model.hamiltonian:
        raise NotImplementedError("RATTLE with a non-Coriolis velocity force is not implemented")
    kick = model.numba_kick

    @jit(inline="always")
    def to_canonical(x, y, vx, vy, p):
        wx = p[P_OMEGA_X]
        wy = p[P_OMEGA_Y]
        wz = p[P_OMEGA_Z]
        length = p[P_LENGTH]
        z = -math.sqrt(length * length - x * x - y * y)
        vz = -(x * vx + y * vy) / z
        return x, y, z, vx + wy * z - wz * y, vy + wz * x - wx * z, vz + wx * y - wy * x

    @jit(inline="always")
    def rotation(c, h, p):
        return _rotation(p[P_OMEGA_X], p[P_OMEGA_Y], p[P_OMEGA_Z], c, h)

    @jit(inline="always")
    def turn(rotation, q):
        x, y, z, px, py, pz = q
        x, y, z = _apply(rotation, x, y, z)
        px, py, pz = _apply(rotation, px, py, pz)
        return x, y, z, px, py, pz

    @jit(inline="always")
    def kick_drift_kick(q, h, p):
        x, y, z, px, py, pz = q
        length = p[P_LENGTH]
        l2 = length * length
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
        return xn, yn, zn, px + nu * xn, py + nu * yn, pz + nu * zn

    @jit(inline="always")
    def from_canonical(q, p):
        x, y, z, px, py, pz = q
        wx = p[P_OMEGA_X]
        wy = p[P_OMEGA_Y]
        wz = p[P_OMEGA_Z]
        return x, y, px - (wy * z - wz * y), py - (wz * x - wx * z)

    return _Parts(to_canonical, rotation, 9, turn, kick_drift_kick, from_canonical)


@jit
def _rotation(wx, wy, wz, c, h):
    """The rotation about ω = (wx, wy, wz) by the angle −|ω| c h as a 3×3 matrix (row-major 9-tuple):
    R = cos a·I + sin a·[n]× + (1 − cos a)·n nᵀ, n = ω/|ω| (Rodrigues' rotation formula in matrix form,
    e.g. Goldstein, Classical Mechanics, 3rd ed., §4.7); the identity when ω = 0. Computed once per run,
    R applies in 9 multiplications and 6 additions instead of Rodrigues' vector form's 18 and 12."""
    rate = math.sqrt(wx * wx + wy * wy + wz * wz)
    if rate == 0.0:
        return 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    nx = wx / rate
    ny = wy / rate
    nz = wz / rate
    angle = -c * rate * h
    cos_a = math.cos(angle)
    sin_a = math.sin(angle)
    u = 1.0 - cos_a
    return (
        cos_a + u * nx * nx, u * nx * ny - sin_a * nz, u * nx * nz + sin_a * ny,
        u * ny * nx + sin_a * nz, cos_a + u * ny * ny, u * ny * nz - sin_a * nx,
        u * nz * nx - sin_a * ny, u * nz * ny + sin_a * nx, cos_a + u * nz * nz,
    )


@jit
def _apply(rotation, vx, vy, vz):
    """R·(vx, vy, vz) for a row-major 3×3 matrix R (``_rotation``)."""
    return (
        rotation[0] * vx + rotation[1] * vy + rotation[2] * vz,
        rotation[3] * vx + rotation[4] * vy + rotation[5] * vz,
        rotation[6] * vx + rotation[7] * vy + rotation[8] * vz,
    )
