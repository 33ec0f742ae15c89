"""ODE integrators for the Foucault-pendulum models, found through a registry.

Importing this package registers the built-in integrators (one module each) and any plug-ins advertised
under the entry-point group ``foucault_bench.integrators``. See ``integrators.base`` for the interface.
"""

from foucault_bench.integrators.base import (
    STATUS_DIVERGED,
    STATUS_FAILED,
    STATUS_OK,
    Integrator,
    Problem,
    Solution,
    StreamedMetrics,
)
from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.registry import REGISTRY, get_integrator, load_plugins, register, unregister

from foucault_bench.integrators import (  # noqa: E402,F401  (registration)
    boris, composition6, cvode, cvode_py, dop853, dopri5, explicit_euler, gauss_legendre4, heyoka_taylor,
    implicit_midpoint, rk4, scipy_ivp, symplectic_euler, tsit5, verlet, yoshida4,
)

load_plugins()

__all__ = [
    "REGISTRY",
    "STATUS_DIVERGED",
    "STATUS_FAILED",
    "STATUS_OK",
    "FixedStepIntegrator",
    "Integrator",
    "Problem",
    "Solution",
    "StreamedMetrics",
    "get_integrator",
    "register",
    "unregister",
]
