"""mpmath's arithmetic backend: the package depends on gmpy2, which mpmath uses when it is installed (its GMP
integers instead of Python's), and the numbers do not depend on it. Every mpmath operation rounds correctly at the
working precision either way, and at the 34-40 digits used here both backends run the same algorithms (mpmath's
backend-dependent cut-offs start at 400 bits), so the results are equal bit for bit, not close: the turning
points' 40-digit Hermite system and the anisotropic model's exact solution, computed here and in a process that
``MPMATH_NOGMPY`` keeps on Python's integers. (The order check's 34-digit steppers compute with MPFR through gmpy2
directly, not with mpmath: ``bench.gate.multiprecision_order``.)"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import mpmath.libmp

COMPUTE = r"""
import json
import mpmath.libmp
import numpy as np
from foucault_bench.bench.problems.turning_points import _hermite_system
from foucault_bench.models import PendulumParameters
from foucault_bench.models.analytic import anisotropic_linear_exact

numbers = {"backend": mpmath.libmp.BACKEND, "hermite": _hermite_system(6).tobytes().hex()}
params = PendulumParameters(length_m=3.0, latitude_deg=48.8, amplitude_m=0.1, support_anisotropy=1e-3)
numbers["anisotropic"] = anisotropic_linear_exact(params, np.linspace(0.0, 500.0, 51)).tobytes().hex()
print(json.dumps(numbers))
"""


def _numbers(environment: dict[str, str]) -> dict[str, object]:
    done = subprocess.run([sys.executable, "-c", COMPUTE], capture_output=True, text=True, env=environment,
                          timeout=300, check=True)
    return json.loads(done.stdout)


def test_mpmath_uses_gmpy2() -> None:
    assert mpmath.libmp.BACKEND == "gmpy"


def test_the_numbers_are_the_same_on_python_integers() -> None:
    environment = {key: value for key, value in os.environ.items() if key != "MPMATH_NOGMPY"}
    gmp = _numbers(environment)
    python = _numbers({**environment, "MPMATH_NOGMPY": "1"})
    assert (gmp.pop("backend"), python.pop("backend")) == ("gmpy", "python")
    assert gmp == python
