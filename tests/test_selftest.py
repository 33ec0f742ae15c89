"""``foucault-bench selftest``: the conformance check passes on every built-in integrator and fails on the
deliberately wrong ones of ``tests/check_mutants.py``; bad input exits 2 with one line and no traceback."""

from __future__ import annotations

import pytest

from foucault_bench.bench.cli import main
from foucault_bench.bench.gate.conformance import check_order, run_checks
from foucault_bench.bench.gate.multiprecision_order import exact_main_method
from foucault_bench.models import MODELS
from foucault_bench.integrators import REGISTRY, built_in_names, get_integrator, unregister
from model_sets import LEAVES_AND_LINEAR

MUTANT_PLUGIN = "check_mutants"


@pytest.fixture(scope="module")
def mutants():
    """The mutants registered for this module only (``check_mutants`` registers them when imported)."""
    import check_mutants

    for cls in (check_mutants.RK4WrongWeights, check_mutants.VerletNaiveCoriolis):
        REGISTRY.setdefault(cls.name, cls())
    yield check_mutants.MUTANT_NAMES
    for name in check_mutants.MUTANT_NAMES:
        unregister(name)


def run_cli(argv: list[str], capsys) -> tuple[int, str, str]:
    status = main(argv)
    captured = capsys.readouterr()
    return status, captured.out, captured.err


ORDER_MODELS = LEAVES_AND_LINEAR
"""The models each built-in integrator's order is checked on here: the linear model (its counters and stability
checks compile it anyway) and the leaves of the refinement hierarchy, which carry every force term of their
ancestors and between them every geometry and every kind of force (``test_the_order_models_cover_every_kind_of_model``).
``foucault-bench selftest NAME`` checks every model; here the other models are checked on one integrator of each
way a scheme reaches the force (``test_every_model_holds_the_order_of_each_way_of_reaching_the_force``), since an
integrator × model product would compile every scheme once per model (the slowest part of the suite)."""

FORCE_ACCESS_REPRESENTATIVES = ("rk4", "verlet", "boris", "implicit_midpoint")
"""One built-in scheme per way a fixed-step scheme reaches a model's force: the acceleration of a Runge-Kutta
stage (rk4), the kick and the velocity-dependent remainder of the Verlet sequences (verlet, the base of every
composition), the free force itself (boris) and the acceleration inside a Newton iteration (implicit_midpoint).
The other schemes, and the embedded pairs' main methods at fixed steps, reach it as one of these does."""


def test_the_order_models_cover_every_kind_of_model() -> None:
    """Between them the order models have every geometry and kind of force of ``MODELS``, and every other model
    is an ancestor of one of them (its force terms are among theirs)."""
    def kind(name: str) -> tuple:
        return MODELS[name].geometry, MODELS[name].hamiltonian, MODELS[name].conserves_energy

    assert {kind(name) for name in ORDER_MODELS} == {kind(name) for name in MODELS}
    reached, frontier = set(ORDER_MODELS), list(ORDER_MODELS)
    while frontier:
        parents = set(MODELS[frontier.pop()].refines) - reached
        reached |= parents
        frontier.extend(parents)
    assert reached == set(MODELS)


@pytest.mark.parametrize("name", built_in_names())
def test_every_built_in_integrator_conforms_to_what_it_declares(name: str) -> None:
    checks = run_checks(get_integrator(name), [MODELS[model] for model in ORDER_MODELS])
    failed = [f"{check.name}: {check.detail}" for check in checks if check.holds is False]
    assert not failed, failed
    applied = {check.name for check in checks if check.holds}
    assert {"counters", "divergence is a row", "failure is a row"} <= applied
    integrator = get_integrator(name)
    exact = exact_main_method(integrator) is not None  # stepped in 34 digits
    if (exact or not integrator.adaptive) and integrator.order is not None:
        assert {f"order on {model}" for model in ORDER_MODELS} <= applied  # each at its example parameters
    if integrator.stability_limit_kh is not None:
        assert {"stable below the limit", "diverges above the limit"} <= applied


@pytest.mark.parametrize("model_name", [name for name in MODELS if name not in ORDER_MODELS])
@pytest.mark.parametrize("name", FORCE_ACCESS_REPRESENTATIVES)
def test_every_model_holds_the_order_of_each_way_of_reaching_the_force(name: str, model_name: str) -> None:
    check = check_order(get_integrator(name), MODELS[model_name])
    assert check.holds, check.detail


def test_each_mutant_fails_its_declared_order(mutants) -> None:
    for name in mutants:
        checks = {check.name: check for check in run_checks(get_integrator(name))}
        assert checks["order on linear"].holds is False, checks["order on linear"]
        assert checks["failure is a row"].holds and checks["divergence is a row"].holds


def test_command_prints_one_line_per_check_and_exits_0_or_1(mutants, capsys) -> None:
    status, out, err = run_cli(["selftest", "verlet"], capsys)
    lines = out.splitlines()
    assert status == 0, out + err
    assert len(lines) == len(run_checks(get_integrator("verlet"))) + 1 and lines[-1].startswith("verlet: ")
    assert all(line.split()[0] in ("ok", "skip") for line in lines[:-1])
    status, out, err = run_cli(["selftest", "rk4_wrong_weights", "--plugin", MUTANT_PLUGIN], capsys)
    assert status == 1 and "FAIL  order on linear" in out, out + err


@pytest.mark.parametrize("argv, expected", [
    (["selftest", "rk5"], "unknown integrator 'rk5' (did you mean 'rk4'?)"),
    (["selftest", "rk4", "--plugin", "no_such_module_here"], "cannot import 'no_such_module_here'"),
    (["selftest", "rk4", "--plugin", "json"], "module 'json' registers no integrator"),
])
def test_bad_input_exits_2_with_one_line(argv, expected, capsys) -> None:
    status, out, err = run_cli(argv, capsys)
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and expected in err and "Traceback" not in err, err


def test_the_stability_line_states_the_measurement_the_criterion_and_the_verdict() -> None:
    """An energy error of 1 that stays 1 (RK4 just below its limit damps the swing away) is bounded: the line
    says so, with both measurements and the bound; growth beyond the bound is stated as not held."""
    from foucault_bench.bench.gate.conformance import GROWTH_ALLOWANCE, ROUND_OFF_GROWTH, stability_verdict

    holds, line = stability_verdict(1.715, 1.0, 1.0)
    assert holds is True
    assert "max relative energy error 1.000e+00 after" in line and ": held" in line and "not growing" in line
    assert f"{1.0 * (1 + GROWTH_ALLOWANCE) + ROUND_OFF_GROWTH:.3e}" in line
    holds, line = stability_verdict(1.715, 1e-3, 2e-3)
    assert holds is False and "NOT held, it grew" in line and "large" not in line
    holds, line = stability_verdict(1.715, 1e-12, 1.5e-12)
    assert holds is True and line.endswith(": held")


def test_every_applied_line_of_the_command_says_whether_it_held(capsys) -> None:
    status, out, _ = run_cli(["selftest", "rk4"], capsys)
    assert status == 0
    for line in out.splitlines()[:-1]:
        label, _, rest = line.partition("  ")
        if rest.startswith(("order on", "stable below", "diverges above")):
            assert label.strip() == "ok" and rest.count(": held") == 1, line


def test_a_scheme_declaring_fewer_stages_than_it_evaluates_fails_the_counters() -> None:
    """Heun's 3-stage step declared as 1 stage: the counted evaluations (integrators.counting) give nfev = 3 × steps,
    and the counters check fails; declared as 3 stages, the same step passes."""
    from foucault_bench.bench.gate.conformance import check_counters_and_turning_points
    from foucault_bench.integrators import FixedStepIntegrator
    from foucault_bench.integrators.explicit_rk import tableau_step
    from foucault_bench.integrators.methods.heun3 import TABLEAU

    class MisDeclared(FixedStepIntegrator):
        name, family, order, stages = "heun3_declared_one_stage", "test", 3, 1
        stability_limit_kh, reference = None, "test: Heun's third-order step declaring one stage"

        def make_step(self, model):
            return tableau_step(TABLEAU, model.numba_acceleration)

    counters = check_counters_and_turning_points(MisDeclared())[0]
    assert counters.name == "counters" and counters.holds is False
    steps = int(counters.detail.split("× ")[-1])
    assert counters.detail == f"nfev = {3 * steps} ≠ stages × steps = 1 × {steps}"
    declared_three = type("DeclaredThree", (MisDeclared,), {"stages": 3})()
    assert check_counters_and_turning_points(declared_three)[0].holds is True


def test_the_high_order_fit_leaves_out_a_round_off_tilted_last_point() -> None:
    """A sweep by 10^(1/10) on the asymptotic line e = h¹⁰ whose last error is lowered to a local slope of 10.7
    instead of 10 (as composition10's last point on the sphere, where round-off met the truncation error): the report's 10 % rule fits it in and sees more
    than 10.05; the high-order sweep's 5 % rule (``order_sweep.fit_order``) leaves it out and sees 10."""
    import numpy as np

    from foucault_bench.bench.gate.order_sweep import HALVING, fit_order, sweep_for
    from foucault_bench.bench.verdicts.convergence import observed_order

    steps = list(0.9 * 10.0 ** (-np.arange(6) / 10.0))
    errors = [h ** 10 for h in steps]
    errors[-1] *= (steps[-1] / steps[-2]) ** 0.7  # local slope 10.7
    assert observed_order(steps, errors) > 10.05
    assert fit_order(sweep_for(10), steps, errors) == pytest.approx(10.0, abs=1e-9)
    assert fit_order(HALVING, steps, errors) == observed_order(steps, errors)
