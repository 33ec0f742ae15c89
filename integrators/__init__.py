"""ODE integrators for the Foucault-pendulum models, found through a registry.

Importing this package imports every module in it (the built-in integrators register themselves; nothing is
listed by hand) and the plug-ins advertised under the entry-point group ``foucault_bench.integrators``
(``integrators.registry``). See ``integrators.base`` for the interface and how to add an integrator.
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
from foucault_bench.integrators.registry import (
    REGISTRY,
    built_in_names,
    discover_built_ins,
    get_integrator,
    is_built_in,
    load_entry_point_plugins,
    register,
    unregister,
)

discover_built_ins()
load_entry_point_plugins()

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
    "built_in_names",
    "get_integrator",
    "is_built_in",
    "register",
    "unregister",
]
