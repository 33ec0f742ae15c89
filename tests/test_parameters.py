"""Parameter validation: every bad field gives a ValueError that names it."""

import math

import numpy as np
import pytest

from foucault_bench.models import PendulumParameters

GOOD = dict(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)


@pytest.mark.parametrize(
    "field, value",
    [
        ("length_m", 0.0),
        ("length_m", -1.0),
        ("length_m", math.nan),
        ("latitude_deg", 90.5),
        ("latitude_deg", -91.0),
        ("latitude_deg", math.inf),
        ("amplitude_m", 67.0),
        ("amplitude_m", 0.0),
        ("gravity_m_s2", 0.0),
        ("earth_rate_rad_s", -1e-5),
        ("release_azimuth_deg", math.nan),
        ("length_m", "67"),
        ("release_velocity_m_s", (0.0,)),
    ],
)
def test_bad_parameter_names_the_field(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=field):
        PendulumParameters(**{**GOOD, field: value})


def test_parameters_are_immutable_and_derived_quantities_follow_the_convention() -> None:
    params = PendulumParameters(**GOOD)
    with pytest.raises(AttributeError):
        params.length_m = 1.0  # type: ignore[misc]
    phi = math.radians(GOOD["latitude_deg"])
    wx, wy, wz = params.omega_vector_rad_s
    # Earth's axis points north (−x in the South-East-Up frame) and up in the northern hemisphere.
    assert wx < 0 and wy == 0 and wz > 0
    assert math.isclose(wz, params.earth_rate_rad_s * math.sin(phi), rel_tol=1e-15)
    assert params.textbook_precession_rate_rad_s == -wz
    # released at y = A (azimuth 90°, the seed's choice) exactly, at rest
    assert np.array_equal(params.initial_state(), [0.0, 3.0, 0.0, 0.0])
