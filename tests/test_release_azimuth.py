"""The two release-azimuth terms of the spherical pendulum's measured precession rate (models/README.md "The release
azimuth"), checked against quadruple-precision references over the release azimuth ψ:

    rate / (−Ω_E sin φ) = 1 − (3/8)θ₀² − ¼θ₀³ cot φ cos ψ − (3/64)θ₀² (Ω_E T) cos φ cot φ sin 2ψ + …

The sin 2ψ term is the mean, over a run of duration T, of an Airy precession that grows linearly in time: the
centrifugal anisotropy Δ(k²) = Ω_E² cos² φ (restoring force weaker East-West than North-South) opens a swing
that is not along an axis into an ellipse whose minor semi-axis grows as b(t) = A·(Δk t/2)·sin 2ψ, Δk = Δ(k²)/2k
(the anisotropic linear pendulum, first order in t), and Airy's rate (3/8)k·A·b/L² of that ellipse, fitted by a
straight line over [0, T], adds (3/8)k θ₀² (Δk/2)(T/2) sin 2ψ. Method: first-order secular perturbation of the
linear swing (Nayfeh, Perturbation Methods, Wiley 1973, §5.2, method of averaging) with Airy's rate (Airy, Mem.
R. Astron. Soc. 20, 121 (1851); Pippard, Proc. R. Soc. Lond. A 420, 81 (1988)).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from foucault_bench.bench.problems.reference import references_for
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.bench.problems.turning_points import azimuth_error_bound, rate_error_bound

AZIMUTHS_DEG = [0.0, 45.0, 90.0, 135.0, 180.0]
SCENE = dataclasses.replace(SCENES["lab_3m"], name="lab_3m_psi", duration_s=900.0)
PARAMS = dataclasses.replace(SCENE.params, amplitude_m=0.3)  # θ₀ = 0.1: both terms well above the measurement


def derived_sin2psi_coefficient(theta0: float, latitude_rad: float, earth_rate_rad_s: float, duration_s: float) -> float:
    """Coefficient D of θ₀³ cot φ sin 2ψ in rate/(−Ω_E sin φ) (module docstring): −(3/64)(Ω_E T) cos φ / θ₀."""
    return -3.0 / 64.0 * earth_rate_rad_s * duration_s * math.cos(latitude_rad) / theta0


def test_release_azimuth_terms_match_the_references() -> None:
    members = [dataclasses.replace(SCENE, params=dataclasses.replace(PARAMS, release_azimuth_deg=azimuth))
               for azimuth in AZIMUTHS_DEG]
    references = references_for(members)
    theta0 = PARAMS.amplitude_m / PARAMS.length_m
    textbook = PARAMS.textbook_precession_rate_rad_s
    unit = theta0**3 / math.tan(PARAMS.latitude_rad)  # θ₀³ cot φ
    residual = np.array([(r.precession_rate_rad_s / textbook - (1.0 - 0.375 * theta0**2)) / unit for r in references])
    psi = np.radians(AZIMUTHS_DEG)
    # least squares on 1, cos ψ, sin 2ψ, cos 2ψ: the constant and cos 2ψ take the higher orders (θ₀⁴, (Ω_E T)²)
    design = np.column_stack([np.ones_like(psi), np.cos(psi), np.sin(2 * psi), np.cos(2 * psi)])
    (_, cos_coefficient, sin2_coefficient, _), *_ = np.linalg.lstsq(design, residual, rcond=None)
    # each rate's worst-case measurement error (bench.problems.turning_points), in the unit, through the fit
    bound = max(rate_error_bound(r.turning_points[:, 0], azimuth_error_bound(PARAMS, SCENE.output_interval_s,
                                                                            SCENE.duration_s)) for r in references)
    propagated = float(np.max(np.sum(np.abs(np.linalg.pinv(design)), axis=1))) * bound / abs(textbook) / unit
    derived = derived_sin2psi_coefficient(theta0, PARAMS.latitude_rad, PARAMS.earth_rate_rad_s, SCENE.duration_s)
    # the derivation is first order in Ω_E T cos φ (0.05 here) and in θ₀: 10 % of the term for what it leaves out
    assert abs(sin2_coefficient - derived) <= 0.1 * abs(derived) + propagated
    assert abs(cos_coefficient + 0.25) <= 0.1 * 0.25 + propagated
    assert abs(derived) > 5.0 * propagated  # the check has teeth: the term is well above the measurement
