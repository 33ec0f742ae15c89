"""Physical parameters of one pendulum at one place, as one immutable, validated value.

Convention (said once, here, and in models/README.md "Frames and conventions"): the suite speaks in **latitude**
φ, in degrees, positive north. The seed note (summarised in reports/README.md "The seed note") writes its rotation
vector as ω(−sin λ, 0, cos λ) with λ the **colatitude**, so its ``ω cos λ`` is our ``Ω_E sin φ``. The local frame
is the seed's: x South, y East, z Up (right-handed). Earth's rotation vector in that frame is Ω_E(−cos φ, 0, sin
φ), and the textbook precession of the swing plane is −Ω_E sin φ about the local upward vertical: clockwise seen
from above in the north, counter-clockwise in the south, none at the equator.

All quantities are SI (m, s, rad/s) except the two angles, which are in degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

SIDEREAL_EARTH_RATE_RAD_S = 7.2921159e-5
"""Earth's sidereal rotation rate 2π / 86164.0905 s (the mean sidereal day; models/README.md "Frames and
conventions")."""

STANDARD_GRAVITY_M_S2 = 9.81

# Layout of the parameter vector handed to every compiled right-hand side (one layout for all models).
P_GRAVITY, P_LENGTH, P_K2, P_OMEGA_X, P_OMEGA_Y, P_OMEGA_Z, P_CENTRIFUGAL = range(7)
PARAMETER_VECTOR_NAMES = ("g", "L", "k2", "omega_x", "omega_y", "omega_z", "centrifugal")


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
    """

    length_m: float
    latitude_deg: float
    amplitude_m: float
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2
    earth_rate_rad_s: float = SIDEREAL_EARTH_RATE_RAD_S
    release_azimuth_deg: float = 90.0
    release_velocity_m_s: tuple[float, float] = (0.0, 0.0)
    centrifugal: bool = True

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            if field.name == "centrifugal":
                if not isinstance(value, (bool, np.bool_)):
                    raise ValueError(f"centrifugal must be true or false, got {value!r}")
                continue
            components = value if field.name == "release_velocity_m_s" else (value,)
            if field.name == "release_velocity_m_s" and len(components) != 2:
                raise ValueError(f"release_velocity_m_s must be a pair (vx, vy) in m/s, got {value!r}")
            for component in components:
                if isinstance(component, bool) or not isinstance(component, (int, float, np.floating, np.integer)):
                    raise ValueError(f"{field.name} must be a real number, got {component!r}")
                if not math.isfinite(component):
                    raise ValueError(f"{field.name} must be finite, got {component!r}")
        if self.length_m <= 0:
            raise ValueError(f"length_m must be > 0 (the string length in m), got {self.length_m!r}")
        if self.gravity_m_s2 <= 0:
            raise ValueError(f"gravity_m_s2 must be > 0, got {self.gravity_m_s2!r}")
        if not -90.0 <= self.latitude_deg <= 90.0:
            raise ValueError(f"latitude_deg must lie in [-90, 90] degrees, got {self.latitude_deg!r}")
        if self.earth_rate_rad_s < 0:
            raise ValueError(f"earth_rate_rad_s must be >= 0, got {self.earth_rate_rad_s!r}")
        if not 0.0 < self.amplitude_m < self.length_m:
            raise ValueError(
                f"amplitude_m must satisfy 0 < amplitude_m < length_m = {self.length_m!r} m, got {self.amplitude_m!r}"
            )
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
    def pendulum_frequency_rad_s(self) -> float:
        """k = √(g/L) (rad/s), the small-swing angular frequency without rotation."""
        return math.sqrt(self.gravity_m_s2 / self.length_m)

    @property
    def small_swing_period_s(self) -> float:
        return 2.0 * math.pi / self.pendulum_frequency_rad_s

    def parameter_vector(self) -> np.ndarray:
        """The float64 vector every compiled right-hand side reads (layout: ``PARAMETER_VECTOR_NAMES``)."""
        wx, wy, wz = self.omega_vector_rad_s
        return np.array(
            [self.gravity_m_s2, self.length_m, self.gravity_m_s2 / self.length_m, wx, wy, wz, float(self.centrifugal)],
            dtype=np.float64,
        )

    def initial_state(self) -> np.ndarray:
        """(x, y, ẋ, ẏ) at t = 0 in m and m/s: released at ``amplitude_m`` along ``release_azimuth_deg``."""
        vx, vy = self.release_velocity_m_s
        cos_psi, sin_psi = _exact_cos_sin_deg(self.release_azimuth_deg)
        return np.array([self.amplitude_m * cos_psi, self.amplitude_m * sin_psi, vx, vy])


def _exact_cos_sin_deg(angle_deg: float) -> tuple[float, float]:
    """cos and sin of an angle in degrees, exact (0, ±1) at multiples of 90° so that x(0) = 0 holds exactly."""
    quarter_turns, remainder = divmod(angle_deg, 90.0)
    if remainder == 0.0:
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(quarter_turns) % 4]
    radians = math.radians(angle_deg)
    return math.cos(radians), math.sin(radians)
