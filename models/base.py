"""The model base: one force source per model, and everything derived from it (written once, here).

A model file writes its equations once, as plain arithmetic over a passed-in math namespace ``m``:

    free_force(m, x, y, z, vx, vy, vz, p) -> (fx, fy, fz)    force per unit mass before any constraint
    energy(m, x, y, vx, vy, p) -> float                     the conserved (or monitored) quantity

``p`` is the parameter vector of ``models.parameters`` (same layout for every model). The model declares its
geometry: ``"plane"`` (state moves in the horizontal plane; z ignored) or ``"sphere"`` (bob on a sphere of
radius L, z = −√(L² − x² − y²) below the pivot). From that one source this module derives

* the right-hand side of the first-order system in the state (x, y, ẋ, ẏ) (``acceleration``), with the
  string's constraint force for the sphere (models/README.md "Spherical model", d'Alembert's principle);
* the split a rotating-frame Verlet needs (integrators/README.md "Rotating-frame Verlet"): the
  position-only kick −∇U(r) = F(r, 0) + ω×(ω×r) acting on the canonical
  momentum p = ṙ + ω×r, and, for non-Hamiltonian models only, the remaining velocity-dependent force
  G(r, ṙ) = F(r, ṙ) − F(r, 0) + 2ω×ṙ;
* numba-compiled versions (``models.jit.jit``, cached on disk; math namespace = the ``math`` module) for
  the fixed-step loops, scipy and CVODE, and heyoka expressions (math namespace = heyoka's functions,
  parameters = ``heyoka.par[i]``) for the Taylor integrator.

No equation is written twice: the compiled and the symbolic forms are the same Python source run over two
namespaces.

**Writing a source** (what both namespaces accept):

* arithmetic (``+ − × / **``) on the arguments, reads ``p[P_NAME]`` of the parameter vector with the indices of
  ``models.parameters`` (never a literal index), module-level numeric constants, and the functions of ``m``
  (``m.sqrt``, ``m.sin``, ``m.cos``; add one to ``heyoka_math`` before using it);
* no branch on a state or parameter value (a heyoka expression has no truth value), no NumPy call, no Python
  object; return floats in every component (a planar model returns ``0.0 * z`` for fz, which keeps numba's
  types uniform);
* **helpers**: a function that a source calls must be decorated with ``models.jit.jitable`` and take the
  namespace ``m`` as its first argument, as ``sphere_height`` below: numba then compiles it into the calling
  source (a plain function would be a Python object to numba and fail to compile), and over heyoka's
  namespace it runs as plain Python that builds expressions. numba keys its disk cache by the fingerprint of
  the source and of everything it reads (``models.jit``), so editing a helper or a constant recompiles.

**Extension points** (models/README.md "Adding a model"): a model is one module of this package with a
module-level ``MODEL = Model(...)``; ``models`` discovers it (no list to edit). ``refines`` declares which
simpler models it adds physics to, which places it in the adequacy hierarchy (``adequacy_hierarchy``,
read by ``bench.verdicts.adequacy``). heyoka is handed its parameter values by ``Model.heyoka_parameters``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np

from foucault_bench.models.jacobian import numba_jacobian_into
from foucault_bench.models.jit import jit, jitable
from foucault_bench.models.parameters import (P_LENGTH, P_OMEGA_X, P_OMEGA_Y, P_OMEGA_Z, PARAMETER_COUNT,
                                              PendulumParameters)

STATE_NAMES = ("x", "y", "vx", "vy")
"""Every model's state: horizontal position (m) and velocity (m/s) in the rotating (South, East, Up) frame."""


@jitable
def sphere_height(m, x, y, vx, vy, p):
    """Height z = −√(L² − x² − y²) (m) of a bob hanging below the pivot and its rate ż = −(xẋ + yẏ)/z (m/s)."""
    length = p[P_LENGTH]
    z = -m.sqrt(length * length - x * x - y * y)
    return z, -(x * vx + y * vy) / z


@jitable
def plane_lift(m, x, y, vx, vy, p):
    """Planar models live in the horizontal plane: z = ż = 0."""
    return 0.0, 0.0


@jitable
def plane_project(x, y, z, vx, vy, vz, fx, fy, fz, p):
    """Planar models: the horizontal components of the force are the acceleration."""
    return fx, fy


@jitable
def sphere_project(x, y, z, vx, vy, vz, fx, fy, fz, p):
    """Bob on a sphere: r̈ = F + μr with μ = −(|ṙ|² + r·F)/L² keeping |r| = L (models/README.md "Spherical model")."""
    length = p[P_LENGTH]
    mu = -(vx * vx + vy * vy + vz * vz + x * fx + y * fy + z * fz) / (length * length)
    return fx + mu * x, fy + mu * y


def compose_acceleration(free_force: Callable, lift: Callable, project: Callable) -> Callable:
    """(ẍ, ÿ) = project(F(lift(x, y, ẋ, ẏ))): the one composition used both by numba and by heyoka."""

    def acceleration(m, x, y, vx, vy, p):
        z, vz = lift(m, x, y, vx, vy, p)
        fx, fy, fz = free_force(m, x, y, z, vx, vy, vz, p)
        return project(x, y, z, vx, vy, vz, fx, fy, fz, p)

    return acceleration


def heyoka_math() -> types.SimpleNamespace:
    """The math namespace in which model sources build heyoka expressions."""
    import heyoka

    return types.SimpleNamespace(sqrt=heyoka.sqrt, sin=heyoka.sin, cos=heyoka.cos)


def _c_library(function: Callable[[float], float]) -> Callable:
    """``function`` of the ``math`` module (the C library's, which numba's compiled code calls too) on a number
    or, element by element, on an array."""
    elementwise = np.frompyfunc(function, 1, 1)

    def apply(value):
        return function(value) if np.ndim(value) == 0 else elementwise(value).astype(np.float64)

    return apply


ARRAY_MATH = types.SimpleNamespace(sqrt=np.sqrt, sin=_c_library(math.sin), cos=_c_library(math.cos))
"""The math namespace in which model sources evaluate on numpy arrays of states (``Model.acceleration_on_rows``,
``Model.energy_on_rows``). The source's arithmetic is then numpy's, operation by operation in the source's order,
and its square roots are correctly rounded: numba's values, bit for bit. sin and cos are the C library's, as in
numba's code (numpy's own may use other approximations on some processors)."""


@dataclass(frozen=True, eq=False)
class Model:
    """A Foucault-pendulum model: its force source, geometry and conserved quantity.

    Attributes:
        name: registry key (``models.get_model``).
        title: one line for tables and charts.
        geometry: ``"plane"`` or ``"sphere"``.
        free_force: the model's force source (module docstring, "Writing a source"); a helper it calls is
            decorated with ``models.jit.jitable`` and takes the math namespace ``m`` first.
        energy: source of the conserved quantity (J/kg), or of the monitored energy where none is conserved.
        energy_name: formula of ``energy`` for tables.
        conserves_energy: whether ``energy`` is an exact invariant of the model.
        hamiltonian: whether every velocity-dependent force is the Coriolis force −2ω_c×ṙ (ω_c: the full
            rotation vector on the sphere, its vertical part (0, 0, Ω_E sin φ) in the plane; ``numba_kick``).
        refines: names of the simpler models this one adds physics to (its direct parents in the adequacy
            hierarchy, e.g. the spherical pendulum refines the seed's planar model); ``()`` for a root.
        example_parameters: field values of ``PendulumParameters`` other than their defaults that exercise
            what this model reads beyond the models it refines (e.g. a new parameter at a value where it acts);
            ``foucault-bench selftest`` and the tests apply them on top of their own parameters
            (``with_example_parameters``), so that a refinement is never checked only where it equals its parents.
        adds_parameters: the fields that switch on all the physics this model adds to the models it refines:
            at their defaults it equals them (``equals_parents_at``), and the adequacy study then compares it with
            none of them (``bench.verdicts.adequacy``). ``()`` (the default): the model differs from its parents
            at every parameter value. Each must appear in ``example_parameters``.
        order_sweep_ellipse: the minor-to-major axis ratio b/a of the swing the order check of ``foucault-bench
            selftest`` releases (``bench.gate.order_sweep.order_parameters``): a sideways release speed of
            b/a · kA. 0 (the default) releases from rest, a planar swing whose speed passes through 0 at every
            turning point and whose position passes through the centre. A model whose force varies on a scale
            far below the swing's there (a smoothed |ṙ|ṙ, a drive concentrated near the centre) has complex
            singularities close to the real time axis on that swing, and a step sweep of a high-order method
            sees its pre-asymptotic errors, not its order; on an ellipse the bob keeps its distance from both.
        taylor_step_watch: source ``(m, x, y, vx, vy, p) -> quantity`` of a term of the force whose Taylor series
            heyoka's step control must see (``heyoka_taylor_system``): one with complex-time singularities close
            to the real axis but too small a weight in the force for the state's own Taylor coefficients to show
            them at the orders of ordinary tolerances (the quadratic drag's smoothed speed, models/README.md
            "Drag and drive"); identically zero where that term is off. ``None`` (the default): none.
    """

    name: str
    title: str
    geometry: str
    free_force: Callable
    energy: Callable
    energy_name: str
    conserves_energy: bool
    hamiltonian: bool
    refines: tuple[str, ...] = ()
    example_parameters: Mapping[str, Any] = field(default_factory=dict)
    adds_parameters: tuple[str, ...] = ()
    order_sweep_ellipse: float = 0.0
    taylor_step_watch: Callable | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= self.order_sweep_ellipse <= 1.0:
            raise ValueError(f"model {self.name!r}: order_sweep_ellipse must lie in [0, 1], "
                             f"got {self.order_sweep_ellipse!r}")
        if self.geometry not in ("plane", "sphere"):
            raise ValueError(f"geometry must be 'plane' or 'sphere', got {self.geometry!r}")
        defaults = {spec.name: spec.default for spec in dataclasses.fields(PendulumParameters)}
        for name, value in self.example_parameters.items():
            if name not in defaults:
                raise ValueError(f"model {self.name!r}: example parameter {name!r} is no field of PendulumParameters")
            if value == defaults[name]:
                raise ValueError(f"model {self.name!r}: example parameter {name} = {value!r} is its default; "
                                 "an example exercises a field away from its default")
        missing = [name for name in self.adds_parameters if name not in self.example_parameters]
        if missing:
            raise ValueError(f"model {self.name!r}: adds_parameters {', '.join(missing)} have no example value "
                             "in example_parameters")

    # --- declared parameters --------------------------------------------------------------------------------
    def with_example_parameters(self, params: PendulumParameters) -> PendulumParameters:
        """``params`` with this model's ``example_parameters`` applied on top."""
        return dataclasses.replace(params, **self.example_parameters)

    def equals_parents_at(self, params: PendulumParameters) -> bool:
        """Whether this model is, at ``params``, the models it refines: it declares ``adds_parameters`` and every
        one of them is at its default value in ``params``."""
        defaults = {spec.name: spec.default for spec in dataclasses.fields(PendulumParameters)}
        return bool(self.adds_parameters) and all(getattr(params, name) == defaults[name]
                                                  for name in self.adds_parameters)

    # --- structure --------------------------------------------------------------------------------------
    @property
    def constrained_to_sphere(self) -> bool:
        return self.geometry == "sphere"

    def _geometry(self) -> tuple[Callable, Callable]:
        return (sphere_height, sphere_project) if self.constrained_to_sphere else (plane_lift, plane_project)

    # --- plain Python evaluation (any namespace) ------------------------------------------------------------
    def acceleration(self, m, x, y, vx, vy, p):
        """(ẍ, ÿ) from the model's source over math namespace ``m``."""
        return compose_acceleration(self.free_force, *self._geometry())(m, x, y, vx, vy, p)

    def acceleration_on_rows(self, states: np.ndarray, p: np.ndarray) -> np.ndarray:
        """(ẍ, ÿ) in m/s² at every row (x, y, ẋ, ẏ) of ``states``: array (n, 2), the values of
        ``numba_acceleration`` bit for bit (``ARRAY_MATH``), at numpy's speed instead of one compiled call per
        row from Python."""
        states = np.asarray(states, dtype=np.float64)
        out = np.empty((states.shape[0], 2))
        with np.errstate(all="ignore"):  # as numba's error_model="numpy": infinities and NaN, no warning
            out[:, 0], out[:, 1] = self.acceleration(ARRAY_MATH, states[:, 0], states[:, 1], states[:, 2],
                                                     states[:, 3], p)
        return out

    def energy_on_rows(self, states: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The energy (J/kg) at every row (x, y, ẋ, ẏ) of ``states``: array (n,), the values of ``numba_energy``
        bit for bit (``ARRAY_MATH``)."""
        states = np.asarray(states, dtype=np.float64)
        out = np.empty(states.shape[0])
        with np.errstate(all="ignore"):
            out[:] = self.energy(ARRAY_MATH, states[:, 0], states[:, 1], states[:, 2], states[:, 3], p)
        return out

    # --- numba ----------------------------------------------------------------------------------------------
    @functools.cached_property
    def numba_free_force(self) -> Callable:
        return jit(self.free_force)

    @functools.cached_property
    def numba_acceleration(self) -> Callable:
        """njit ``(x, y, vx, vy, p) -> (ax, ay)``."""
        source = jit(compose_acceleration(self.numba_free_force, *self._geometry()))

        @jit
        def acceleration(x, y, vx, vy, p):
            return source(math, x, y, vx, vy, p)

        return acceleration

    @functools.cached_property
    def numba_energy(self) -> Callable:
        """njit ``(x, y, vx, vy, p) -> float``."""
        source = jit(self.energy)

        @jit
        def energy(x, y, vx, vy, p):
            return source(math, x, y, vx, vy, p)

        return energy

    @functools.cached_property
    def numba_kick(self) -> Callable:
        """njit ``(x, y, z, p) -> (fx, fy, fz)``: −∇U(r) = F(r, 0) + ω_c×(ω_c×r), the position-only force on
        the canonical momentum p = ṙ + ω_c×r (ω_c the full rotation vector on the sphere,
        its vertical part (0, 0, Ω_E sin φ) in the planar models, where z = 0)."""
        force = self.numba_free_force
        full_rotation = self.constrained_to_sphere

        @jit
        def kick(x, y, z, p):
            wx = p[P_OMEGA_X] if full_rotation else 0.0
            wy = p[P_OMEGA_Y] if full_rotation else 0.0
            wz = p[P_OMEGA_Z]
            fx, fy, fz = force(math, x, y, z, 0.0, 0.0, 0.0, p)
            wrx = wy * z - wz * y
            wry = wz * x - wx * z
            wrz = wx * y - wy * x
            return fx + wy * wrz - wz * wry, fy + wz * wrx - wx * wrz, fz + wx * wry - wy * wrx

        return kick

    @functools.cached_property
    def numba_remainder(self) -> Callable:
        """njit ``(x, y, z, vx, vy, vz, p) -> (gx, gy, gz)``: G(r, ṙ) = F(r, ṙ) − F(r, 0) + 2ω_c×ṙ, the
        velocity-dependent force that is not Coriolis (identically zero for Hamiltonian models)."""
        force = self.numba_free_force
        full_rotation = self.constrained_to_sphere

        @jit
        def remainder(x, y, z, vx, vy, vz, p):
            wx = p[P_OMEGA_X] if full_rotation else 0.0
            wy = p[P_OMEGA_Y] if full_rotation else 0.0
            wz = p[P_OMEGA_Z]
            fx, fy, fz = force(math, x, y, z, vx, vy, vz, p)
            f0x, f0y, f0z = force(math, x, y, z, 0.0, 0.0, 0.0, p)
            return (
                fx - f0x + 2.0 * (wy * vz - wz * vy),
                fy - f0y + 2.0 * (wz * vx - wx * vz),
                fz - f0z + 2.0 * (wx * vy - wy * vx),
            )

        return remainder

    @functools.cached_property
    def numba_rhs_into(self) -> Callable:
        """njit ``(t, y, out, p) -> None``: the first-order system dy/dt written into ``out`` (CVODE style)."""
        acceleration = self.numba_acceleration

        @jit
        def rhs_into(t, y, out, p):
            ax, ay = acceleration(y[0], y[1], y[2], y[3], p)
            out[0] = y[2]
            out[1] = y[3]
            out[2] = ax
            out[3] = ay

        return rhs_into

    @functools.cached_property
    def numba_rhs(self) -> Callable:
        """njit ``(t, y, p) -> ndarray``: the first-order system dy/dt as a new array (scipy style)."""
        rhs_into = self.numba_rhs_into

        @jit
        def rhs(t, y, p):
            out = np.empty(4)
            rhs_into(t, y, out, p)
            return out

        return rhs

    # --- heyoka ---------------------------------------------------------------------------------------------
    def heyoka_system(self) -> list:
        """The first-order system as heyoka (variable, expression) pairs, parameters as ``heyoka.par[i]``
        in the layout of ``models.parameters.PARAMETER_SLOTS``."""
        import heyoka

        x, y, vx, vy = heyoka.make_vars(*STATE_NAMES)
        pars = [heyoka.par[i] for i in range(PARAMETER_COUNT)]
        ax, ay = self.acceleration(heyoka_math(), x, y, vx, vy, pars)
        return [(x, vx), (y, vy), (vx, ax), (vy, ay)]

    def heyoka_taylor_system(self) -> list:
        """The system heyoka's Taylor integrators propagate: ``heyoka_system`` and, for a model with a
        ``taylor_step_watch`` q, a fifth variable w with ẇ = Σ_i ∂q/∂s_i ṡ_i, i.e. q along the solution when it
        starts at q's value (``taylor_initial_state``). w feeds back into nothing, so the four equations and
        their Taylor coefficients are those of ``heyoka_system``; heyoka sizes each step from the last two
        Taylor coefficients of every variable (Jorba & Zou, Exp. Math. 14, 99 (2005)), so w's make it see q's
        singularities and shorten its steps near them."""
        import heyoka

        system = self.heyoka_system()
        if self.taylor_step_watch is None:
            return system
        variables = [variable for variable, _ in system]
        watched = self.taylor_step_watch(heyoka_math(), *variables, [heyoka.par[i] for i in range(PARAMETER_COUNT)])
        rate = heyoka.sum([heyoka.diff(watched, variable) * rhs for variable, rhs in system])
        return system + [(heyoka.make_vars("taylor_step_watch"), rate)]

    def taylor_initial_state(self, state: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The initial state of ``heyoka_taylor_system`` for the model's state and full parameter vector ``p``:
        the state, and the watched quantity's value there for a model with a ``taylor_step_watch``."""
        if self.taylor_step_watch is None:
            return np.asarray(state, dtype=np.float64)
        return np.append(state, self.taylor_step_watch(math, *state, p))

    @functools.cached_property
    def heyoka_parameter_count(self) -> int:
        """How many leading entries of the parameter vector ``heyoka_system`` reads: heyoka integrators and
        compiled functions want exactly (highest ``par`` index used + 1) values, e.g. 6 for the linear model,
        which never reads the centrifugal switch p[6]."""
        import heyoka

        used = heyoka.get_params([rhs for _, rhs in self.heyoka_system()])
        return 1 + max((i for i in range(PARAMETER_COUNT) if heyoka.par[i] in used), default=-1)

    def heyoka_parameters(self, vectors: np.ndarray) -> np.ndarray:
        """The values heyoka's integrators and compiled functions take for this model's ``heyoka.par``: the
        leading ``heyoka_parameter_count`` entries of a full parameter vector (shape (PARAMETER_COUNT,)) or of
        each row of a stack of them (shape (n, PARAMETER_COUNT); transpose for a batch integrator).
        The one place that slices the vector for heyoka; ``ValueError`` for a vector of another length."""
        vectors = np.asarray(vectors)
        if vectors.shape[-1:] != (PARAMETER_COUNT,):
            raise ValueError(f"expected full parameter vectors of length {PARAMETER_COUNT}, got shape {vectors.shape}")
        return vectors[..., : self.heyoka_parameter_count]

    @functools.cached_property
    def jacobian_into(self) -> Callable:
        """``(t, y, out, p) -> None``: the Jacobian ∂(dy/dt)/∂y of the first-order system written into the
        C-contiguous (4, 4) array ``out`` (row i = component of dy/dt, column j = state variable).

        Derived from the model's one source: heyoka differentiates the expressions of ``heyoka_system``
        symbolically (``heyoka.diff``) and compiles the 16 derivatives with ``heyoka.cfunc`` (JIT, kept in
        heyoka's on-disk cache). ``t`` is unused (every model is autonomous); ``p`` is the full parameter vector.
        """
        import heyoka

        system = self.heyoka_system()
        variables = [variable for variable, _ in system]
        derivatives = [heyoka.diff(rhs, variable) for _, rhs in system for variable in variables]
        compiled = heyoka.cfunc(derivatives, vars=variables)
        # the compiled derivatives take as many parameters as they read: fewer than the right-hand side when a
        # parameter only adds a term that does not depend on the state (a constant force), whose derivatives vanish
        read = heyoka.get_params(derivatives)
        count = 1 + max((index for index in range(self.heyoka_parameter_count) if heyoka.par[index] in read),
                        default=-1)
        heyoka_parameters = self.heyoka_parameters

        def jacobian_into(t, y, out, p):
            compiled(y, pars=heyoka_parameters(p)[..., :count], outputs=np.reshape(out, -1, copy=False))  # raises rather than copy

        return jacobian_into

    @functools.cached_property
    def numba_jacobian_into(self) -> Callable:
        """njit ``(t, y, out, p) -> None``: the same derivatives as ``jacobian_into``, compiled by numba for
        callers in compiled code (CVODE's Jacobian callback); equal to it to round-off (``models.jacobian``)."""
        return numba_jacobian_into(self.heyoka_system(), self.name)

    @functools.cached_property
    def jacobian(self) -> Callable:
        """``(t, y, p) -> ndarray (4, 4)``: ``jacobian_into`` returning a new array (scipy style)."""
        jacobian_into = self.jacobian_into

        def jacobian(t, y, p):
            out = np.empty((4, 4))
            jacobian_into(t, y, out, p)
            return out

        return jacobian
