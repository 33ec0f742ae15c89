"""Physical parameters of one pendulum at one place, as one immutable, validated value.

Convention (said once, here, and in models/README.md "Frames and conventions"): the suite speaks in **latitude**
φ, in degrees, positive north. The seed note (summarised in reports/README.md "The seed note") writes its rotation
vector as ω(−sin λ, 0, cos λ) with λ the **colatitude**, so its ``ω cos λ`` is our ``Ω_E sin φ``. The local frame
is the seed's: x South, y East, z Up (right-handed). Earth's rotation vector in that frame is Ω_E(−cos φ, 0, sin
φ), and the textbook precession of the swing plane is −Ω_E sin φ about the local upward vertical: clockwise seen
from above in the north, counter-clockwise in the south, none at the equator.

All quantities are SI (m, s, rad/s) except the two angles, which are in degrees.

**Extension points** (models/README.md "Adding a model"):

* a physical parameter is one field of ``PendulumParameters`` with its rule in the field's metadata
  (``rule(check, requirement)``): ``__post_init__`` checks the type of every field and then each rule, in field
  order, and names the field in the error;
* the parameter vector that compiled code reads is defined once, by ``PARAMETER_SLOTS`` (name, unit, how the
  value follows from the fields, and the name of its index constant). A field whose rule gives a ``unit``
  (``rule(..., unit="1")``) is appended to the vector as itself, after the derived slots, so a new physical
  parameter is one field line. Every index constant (``P_GRAVITY`` ..., ``P_<NAME>`` for a field appended as
  itself), the length ``PARAMETER_COUNT`` and ``PARAMETER_VECTOR_NAMES`` are derived from the table; nothing
  else in the suite writes a length or an index.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, Callable

import numpy as np

SIDEREAL_EARTH_RATE_RAD_S = 7.2921159e-5
"""Earth's sidereal rotation rate 2π / 86164.0905 s (the mean sidereal day; models/README.md "Frames and
conventions")."""

STANDARD_GRAVITY_M_S2 = 9.81


def rule(check: Callable[[Any, "PendulumParameters"], bool] | None = None, requirement: str = "",
         kind: str = "real", unit: str | None = None, refinement: bool = False, meaning: str = "") -> dict:
    """Field metadata: ``check(value, params)`` must hold, else ValueError "FIELD REQUIREMENT, got VALUE"
    (``requirement`` may name other fields as ``{p.length_m}``); ``None``: no rule beyond the kind. ``kind``:
    "real" (a finite real number), "pair" (two of them) or "bool". ``unit``: the field enters the parameter
    vector as itself, in that unit, with the index constant ``P_<FIELD NAME IN CAPITALS>``. ``refinement``: the
    field belongs to a refining model and its default changes nothing; a scene's key leaves it out while it has
    its default (``bench.problems.scene_key``), so adding such a field keeps every existing scene's key.
    ``meaning``: what the field is, for a field without a line in the ``PendulumParameters`` docstring (a new
    field is then one line; the scene-key table of bench/README.md reads either)."""
    return {"check": check, "requirement": requirement, "kind": kind, "unit": unit, "refinement": refinement,
            "meaning": meaning}


def airy_fraction(swing_angle_rad: float) -> float:
    """(3/8)θ₀²: by how much (relative) a spherical pendulum released from rest at the angle θ₀ precesses slower
    than −Ω_E sin φ, to leading order (G. B. Airy, "On the vibration of a free pendulum in an oval differing
    little from a straight line", Mem. R. Astron. Soc. 20, 121-130, 1851; M. G. Olsson, Am. J. Phys. 49, 531,
    1981)."""
    return 0.375 * swing_angle_rad**2


@dataclass(frozen=True)
class PendulumParameters:
    """One pendulum at one place, released at a given amplitude and azimuth.

    Attributes:
        length_m: string length L (m), > 0.
        latitude_deg: geographic latitude φ (degrees, north positive), in [−90, 90].
        amplitude_m: horizontal distance of the release point from the vertical (m), 0 < A < L.
        gravity_m_s2: g (m/s²), > 0.
        earth_rate_rad_s: Earth's rotation rate Ω_E (rad/s), ≥ 0 (0 switches rotation off).
        release_azimuth_deg: direction of the release point, measured from x (South) towards y (East), degrees.
            The seed releases at y = y₀, that is 90°.
        release_velocity_m_s: initial horizontal velocity (ẋ, ẏ) in the rotating frame (m/s); the seed's is 0.
        centrifugal: keep the centrifugal force −ω×(ω×r) in the spherical model (the planar models have none).
        support_anisotropy: ε, the support's relative frequency split: small-swing frequencies k(1 ± ε/2) along
            and across its stiff axis (models ``anisotropic_linear``, ``anisotropic_spherical``); 0 (the default):
            an isotropic support.
        anisotropy_axis_deg: β, azimuth of the stiff axis (frequency k(1 + ε/2)), from South towards East, degrees.
        drag_linear_per_s: γ, linear (viscous) drag −γ ṙ per unit mass (1/s; ``damped_linear``); 0: none.
        drag_quadratic_per_m: c, quadratic air drag −c |ṙ| ṙ per unit mass (1/m; ``damped_linear``); 0: none.
        drive_gain_per_s: κ, gain of the drive near the centre, +κ ṙ / (1 + |r|²/r_d²) per unit mass (1/s;
            ``driven_linear``); 0: no drive.
        drive_radius_m: r_d, the radius (m) of the region round the centre where the drive acts.

    A field added later may give its meaning in its rule instead (``rule(..., meaning="...")``), so that a new
    parameter is one line (models/README.md "Adding a model").
    """

    length_m: float = field(metadata=rule(lambda v, p: v > 0, "must be > 0 (the string length in m)"))
    latitude_deg: float = field(metadata=rule(lambda v, p: -90.0 <= v <= 90.0, "must lie in [-90, 90] degrees"))
    amplitude_m: float = field(metadata=rule(lambda v, p: 0.0 < v < p.length_m,
                                             "must satisfy 0 < amplitude_m < length_m = {p.length_m!r} m"))
    gravity_m_s2: float = field(default=STANDARD_GRAVITY_M_S2, metadata=rule(lambda v, p: v > 0, "must be > 0"))
    earth_rate_rad_s: float = field(default=SIDEREAL_EARTH_RATE_RAD_S,
                                    metadata=rule(lambda v, p: v >= 0, "must be >= 0"))
    release_azimuth_deg: float = field(default=90.0, metadata=rule())
    release_velocity_m_s: tuple[float, float] = field(default=(0.0, 0.0),
                                                      metadata=rule(kind="pair"))
    centrifugal: bool = field(default=True, metadata=rule(kind="bool"))
    support_anisotropy: float = field(default=0.0, metadata=rule(lambda v, p: 0.0 <= v < 1.0, "must lie in [0, 1)",
                                                                 unit="1", refinement=True))
    anisotropy_axis_deg: float = field(default=0.0, metadata=rule(unit="deg", refinement=True))
    drag_linear_per_s: float = field(default=0.0, metadata=rule(lambda v, p: v >= 0, "must be >= 0", unit="1/s", refinement=True))
    drag_quadratic_per_m: float = field(default=0.0, metadata=rule(lambda v, p: v >= 0, "must be >= 0", unit="1/m", refinement=True))
    drive_gain_per_s: float = field(default=0.0, metadata=rule(lambda v, p: v >= 0, "must be >= 0", unit="1/s", refinement=True))
    drive_radius_m: float = field(default=0.1, metadata=rule(lambda v, p: v > 0, "must be > 0", unit="m", refinement=True))

    def __post_init__(self) -> None:
        for spec in fields(self):
            value = getattr(self, spec.name)
            kind = spec.metadata["kind"]
            if kind == "bool":
                if not isinstance(value, (bool, np.bool_)):
                    raise ValueError(f"{spec.name} must be true or false, got {value!r}")
                continue
            components = value if kind == "pair" else (value,)
            if kind == "pair" and (not isinstance(value, (tuple, list)) or len(value) != 2):
                raise ValueError(f"{spec.name} must be a pair (vx, vy) in m/s, got {value!r}")
            for component in components:
                if isinstance(component, bool) or not isinstance(component, (int, float, np.floating, np.integer)):
                    raise ValueError(f"{spec.name} must be a real number, got {component!r}")
                if not math.isfinite(component):
                    raise ValueError(f"{spec.name} must be finite, got {component!r}")
        for spec in fields(self):
            value = getattr(self, spec.name)
            check = spec.metadata["check"]
            if check is not None and not check(value, self):
                raise ValueError(f"{spec.name} {spec.metadata['requirement'].format(p=self)}, got {value!r}")
        object.__setattr__(self, "release_velocity_m_s", tuple(float(v) for v in self.release_velocity_m_s))

    @property
    def latitude_rad(self) -> float:
        return math.radians(self.latitude_deg)

    @property
    def omega_vector_rad_s(self) -> tuple[float, float, float]:
        """Earth's rotation vector in the local (South, East, Up) frame: Ω_E(−cos φ, 0, sin φ), rad/s."""
        phi = self.latitude_rad
        return (-self.earth_rate_rad_s * math.cos(phi), 0.0, self.earth_rate_rad_s * math.sin(phi))

    @property
    def vertical_rate_rad_s(self) -> float:
        """a = Ω_E sin φ (rad/s), the vertical component of Earth's rotation (the seed's α = ω cos λ)."""
        return self.omega_vector_rad_s[2]

    @property
    def textbook_precession_rate_rad_s(self) -> float:
        """−Ω_E sin φ (rad/s), counter-clockwise about local up positive (models/README.md "Frames and conventions")."""
        return -self.vertical_rate_rad_s

    @property
    def swing_angle_rad(self) -> float:
        """θ₀ = A/L, the release amplitude as an angle to the order the finite-swing corrections need."""
        return self.amplitude_m / self.length_m

    @property
    def airy_precession_rate_rad_s(self) -> float:
        """Airy's precession rate of a spherical pendulum released from rest, −Ω_E sin φ (1 − (3/8)θ₀²) (rad/s):
        the Coriolis force opens the swing into a thin ellipse, whose own precession runs against the Earth's by
        (3/8)θ₀² of it (``airy_fraction``; models/README.md "Airy precession")."""
        return self.textbook_precession_rate_rad_s * (1.0 - airy_fraction(self.swing_angle_rad))

    @property
    def pendulum_frequency_rad_s(self) -> float:
        """k = √(g/L) (rad/s), the small-swing angular frequency without rotation."""
        return math.sqrt(self.gravity_m_s2 / self.length_m)

    @property
    def small_swing_period_s(self) -> float:
        return 2.0 * math.pi / self.pendulum_frequency_rad_s

    def parameter_vector(self) -> np.ndarray:
        """The float64 vector every compiled right-hand side reads, in the layout of ``PARAMETER_SLOTS``."""
        return np.array([slot.value(self) for slot in _layout(type(self))], dtype=np.float64)

    def initial_state(self) -> np.ndarray:
        """(x, y, ẋ, ẏ) at t = 0 in m and m/s: released at ``amplitude_m`` along ``release_azimuth_deg``."""
        vx, vy = self.release_velocity_m_s
        cos_psi, sin_psi = _exact_cos_sin_deg(self.release_azimuth_deg)
        return np.array([self.amplitude_m * cos_psi, self.amplitude_m * sin_psi, vx, vy])


@dataclass(frozen=True)
class ParameterSlot:
    """One entry of the parameter vector: its name, unit, value for given parameters, and the name of the
    module-level index constant (``P_<NAME>`` unless given)."""

    name: str
    unit: str
    value: Callable[[PendulumParameters], float]
    constant: str = ""

    @property
    def index_constant(self) -> str:
        return self.constant or f"P_{self.name.upper()}"


def _field_slot(name: str, unit: str) -> ParameterSlot:
    return ParameterSlot(name, unit, lambda p: float(getattr(p, name)))


DERIVED_SLOTS: tuple[ParameterSlot, ...] = (
    ParameterSlot("g", "m/s²", lambda p: p.gravity_m_s2, "P_GRAVITY"),
    ParameterSlot("L", "m", lambda p: p.length_m, "P_LENGTH"),
    ParameterSlot("k2", "1/s²", lambda p: p.gravity_m_s2 / p.length_m, "P_K2"),
    ParameterSlot("omega_x", "rad/s", lambda p: p.omega_vector_rad_s[0], "P_OMEGA_X"),
    ParameterSlot("omega_y", "rad/s", lambda p: p.omega_vector_rad_s[1], "P_OMEGA_Y"),
    ParameterSlot("omega_z", "rad/s", lambda p: p.omega_vector_rad_s[2], "P_OMEGA_Z"),
    ParameterSlot("centrifugal", "1 or 0", lambda p: float(p.centrifugal), "P_CENTRIFUGAL"),
)
"""The slots computed from several fields or converted (the first entries of the vector, in this order)."""

def parameter_slots(parameters_class: type = PendulumParameters) -> tuple[ParameterSlot, ...]:
    """The layout of the parameter vector for ``parameters_class``: ``DERIVED_SLOTS``, then every field
    declared with a ``unit``, in field order."""
    return DERIVED_SLOTS + tuple(_field_slot(spec.name, spec.metadata["unit"]) for spec in fields(parameters_class)
                                 if spec.metadata.get("unit") is not None)


def index_constants(slots: tuple[ParameterSlot, ...]) -> dict[str, int]:
    """``{index constant name: index}`` of a layout; ``ValueError`` if two slots share a name or a constant."""
    constants = {slot.index_constant: index for index, slot in enumerate(slots)}
    if len(constants) != len(slots) or len({slot.name for slot in slots}) != len(slots):
        raise ValueError(f"two parameter slots share a name or an index constant: {[slot.name for slot in slots]}")
    return constants


PARAMETER_SLOTS: tuple[ParameterSlot, ...] = parameter_slots()
"""The layout of the parameter vector handed to every compiled right-hand side (one layout for all models).
Add a field with ``rule(..., unit=...)`` (or a slot to ``DERIVED_SLOTS``) to give models a new quantity; the
indices below follow."""

PARAMETER_VECTOR_NAMES: tuple[str, ...] = tuple(slot.name for slot in PARAMETER_SLOTS)
PARAMETER_COUNT = len(PARAMETER_SLOTS)
PARAMETER_INDEX: dict[str, int] = {name: index for index, name in enumerate(PARAMETER_VECTOR_NAMES)}
INDEX_CONSTANTS: dict[str, int] = index_constants(PARAMETER_SLOTS)
"""Every index constant by name, as defined at module level (``P_GRAVITY = 0`` ...), derived from the table."""

# The built-in slots' constants, declared for readers and type checkers; the values come from the table.
P_GRAVITY: int
P_LENGTH: int
P_K2: int
P_OMEGA_X: int
P_OMEGA_Y: int
P_OMEGA_Z: int
P_CENTRIFUGAL: int
globals().update(INDEX_CONSTANTS)


def _layout(parameters_class: type) -> tuple[ParameterSlot, ...]:
    return PARAMETER_SLOTS if parameters_class is PendulumParameters else parameter_slots(parameters_class)


def _exact_cos_sin_deg(angle_deg: float) -> tuple[float, float]:
    """cos and sin of an angle in degrees, exact (0, ±1) at multiples of 90° so that x(0) = 0 holds exactly."""
    quarter_turns, remainder = divmod(angle_deg, 90.0)
    if remainder == 0.0:
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(quarter_turns) % 4]
    radians = math.radians(angle_deg)
    return math.cos(radians), math.sin(radians)
