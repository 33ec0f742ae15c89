"""The registry: built-ins are discovered module by module, declared facts are checked at registration, and
built-ins are told apart from plug-ins."""

from __future__ import annotations

import pkgutil
import sys
from typing import ClassVar

import pytest

import foucault_bench.integrators as integrators_package
import foucault_bench.integrators.methods as methods_package
from foucault_bench.integrators import REGISTRY, FixedStepIntegrator, built_in_names, is_built_in, register, unregister
from foucault_bench.integrators.methods.rk4 import RK4


def test_every_method_module_is_imported_and_registers_and_the_framework_registers_nothing() -> None:
    methods = [info.name for info in pkgutil.iter_modules(methods_package.__path__, methods_package.__name__ + ".")]
    framework = [info.name for info in pkgutil.iter_modules(integrators_package.__path__,
                                                            integrators_package.__name__ + ".") if not info.ispkg]
    assert methods and all(name in sys.modules for name in methods)
    defining = {type(integrator).__module__ for name, integrator in REGISTRY.items() if is_built_in(name)}
    assert defining == set(methods), "every module of integrators/methods/ registers a method, and only they do"
    assert not defining & set(framework)
    assert {"rk4", "verlet", "cvode_bdf", "heyoka_taylor_quad"} <= set(built_in_names())


def make_class(**facts) -> type:
    attributes = {"name": "toy_declared", "family": "toy", "order": 2, "stages": 2, "stability_limit_kh": None,
                  "reference": "test", "make_step": lambda self, model: None, **facts}
    attributes = {key: value for key, value in attributes.items() if value is not Ellipsis}
    return type("ToyDeclared", (FixedStepIntegrator,), attributes)


@pytest.mark.parametrize("facts, message", [
    ({"order": ...}, "missing class attribute 'order'"),
    ({"order": 0}, "order must be a positive integer or None"),
    ({"stages": 1.5}, "stages must be a positive integer or None"),
    ({"stability_limit_kh": -1.0}, "stability_limit_kh must be a finite number > 0"),
    ({"stability_limit_kh": 2.0, "adaptive": True}, "stability_limit_kh applies to fixed-step methods only"),
    ({"family": ""}, "family must be a non-empty string"),
    ({"name": "two words"}, "name must be an identifier-like string"),
])
def test_register_refuses_malformed_declarations(facts, message) -> None:
    with pytest.raises(TypeError, match=message):
        register(make_class(**facts))
    assert "toy_declared" not in REGISTRY and "two words" not in REGISTRY


def test_a_class_defined_outside_the_package_is_a_plug_in() -> None:
    class Outside(RK4):
        name: ClassVar[str] = "outside_rk4"

    register(Outside)
    try:
        assert not is_built_in("outside_rk4") and "outside_rk4" not in built_in_names()
        assert is_built_in("rk4")
    finally:
        unregister("outside_rk4")
