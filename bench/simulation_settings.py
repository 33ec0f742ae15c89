"""What one ``foucault-bench simulate`` run integrates: the settings, with their defaults (standard library only,
so that the command's ``--help`` shows them without importing the simulation)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from foucault_bench.models import PendulumParameters


@dataclass(frozen=True)
class SimulationSettings:
    """What one simulation integrates. Earth's rate is given as a multiple of the sidereal Ω_E."""

    earth_rate_factor: float = 1.0
    latitude_deg: float = 48.846
    length_m: float = 67.0
    amplitude_m: float = 3.0
    hours: float = 1.0
    model: str = "linear"
    integrator: str = "verlet"
    setting: float = 0.05
    """k·h for a fixed-step integrator, the tolerance for an adaptive one."""

    @property
    def earth_rate_rad_s(self) -> float:
        from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S

        return self.earth_rate_factor * SIDEREAL_EARTH_RATE_RAD_S

    def params(self) -> PendulumParameters:
        from foucault_bench.models import PendulumParameters

        return PendulumParameters(length_m=self.length_m, latitude_deg=self.latitude_deg,
                                  amplitude_m=self.amplitude_m, earth_rate_rad_s=self.earth_rate_rad_s)
