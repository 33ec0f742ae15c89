"""A batch of members (integrators.batch) gives each member the solution it gets alone: bitwise for the compiled
fixed-step loops and embedded Runge-Kutta drivers, to round-off for heyoka's batch mode; references in batch
(bench.problems.reference.references_for) are the references computed alone."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from foucault_bench.bench.problems.reference import CACHE_ENVIRONMENT_VARIABLE, reference_for, references_for
from foucault_bench.bench.problems.scenes import SCENES, Scene
from foucault_bench.integrators import Problem, Solution, get_integrator
from foucault_bench.integrators.adaptive import state_scale
from foucault_bench.integrators.batch import solve_batch
from foucault_bench.integrators.batch_heyoka import lanes

HEYOKA_BATCH_BOUND = 1.0e-13
"""Largest |batch − alone| of a state component over its scale (``state_scale``) for heyoka's batch mode on the
90-s scenes below. Measured on this machine (AVX-512, 8 lanes): ≤ 3.5e-15 over 90 s of the 3 m pendulum and
≤ 1.2e-14 over 900 s (round-off of the SIMD elementary functions, growing with the steps); the bound is about
30× the 90-s figure."""


def members(scene: Scene, **sweep: list[float]) -> list[Scene]:
    """Copies of ``scene`` with one parameter swept (the keyword's values)."""
    (field, values), = sweep.items()
    return [dataclasses.replace(scene, params=dataclasses.replace(scene.params, **{field: value})) for value in values]


LAB_90S = dataclasses.replace(SCENES["lab_3m"], name="lab_3m_90s", duration_s=90.0)
AZIMUTHS = members(LAB_90S, release_azimuth_deg=[0.0, 30.0, 45.0, 90.0, 135.0, 170.0, 200.0, 315.0, 355.0])
LENGTHS = members(LAB_90S, length_m=[2.0, 3.0, 4.5])


def same(batch: Solution, alone: Solution) -> bool:
    """Every field of the two solutions equal, states and streamed metrics bitwise."""
    def streamed(solution: Solution) -> tuple | None:
        metrics = solution.streamed
        return None if metrics is None else (metrics.turning_points.tobytes(), np.array(
            [metrics.energy_max_rel_error, metrics.energy_drift_per_s]).tobytes())  # bits: NaN equals NaN

    fields = ("status", "message", "nfev", "njev", "steps", "rejected_steps", "step_size_s", "tolerance", "extra")
    return (batch.y.tobytes() == alone.y.tobytes() and batch.t.tobytes() == alone.t.tobytes()
            and all(getattr(batch, name) == getattr(alone, name) for name in fields)
            and streamed(batch) == streamed(alone))


@pytest.mark.parametrize("name, kh", [("rk4", 0.1), ("verlet", 0.1), ("yoshida4", 0.3), ("boris", 0.1),
                                      ("gauss_legendre4", 0.3)])
@pytest.mark.parametrize("monitor", [False, True])
def test_fixed_step_batch_is_bitwise_the_members_alone(name: str, kh: float, monitor: bool) -> None:
    integrator = get_integrator(name)
    for scenes in (AZIMUTHS, LENGTHS):  # one step for all, one step per member (kh fixed, k varies)
        problems = [scene.problem() for scene in scenes]
        steps = [kh / scene.params.pendulum_frequency_rad_s for scene in scenes]
        batch = solve_batch(integrator, problems, step_s=steps, monitor=monitor)
        alone = [integrator.solve(problem, step_s=step, monitor=monitor) for problem, step in zip(problems, steps, strict=True)]
        assert all(same(b, a) for b, a in zip(batch, alone, strict=True))
        assert len({b.y.tobytes() for b in batch}) == len(batch)  # the members differ: the check has teeth


def test_a_diverging_member_diverges_alone_and_in_the_batch() -> None:
    # explicit Euler at kh = 0.5 leaves 1000 L within the 90 s; the batch keeps its message and NaN rows
    problems = [scene.problem() for scene in AZIMUTHS[:3]]
    step_s = 0.5 / LAB_90S.params.pendulum_frequency_rad_s
    integrator = get_integrator("explicit_euler")
    batch = solve_batch(integrator, problems, step_s=step_s, monitor=True)
    alone = [integrator.solve(problem, step_s=step_s) for problem in problems]
    assert all(b.status == "diverged" and same(b, a) for b, a in zip(batch, alone, strict=True))


@pytest.mark.parametrize("name, tol", [("dopri5", 1e-8), ("dop853", 1e-11), ("tsit5", 1e-6), ("cvode_adams", 1e-8)])
@pytest.mark.parametrize("monitor", [False, True])
def test_adaptive_compiled_batch_is_bitwise_the_members_alone(name: str, tol: float, monitor: bool) -> None:
    # every member keeps its own step-size control: the same accepted and rejected steps as alone
    integrator = get_integrator(name)
    problems = [scene.problem() for scene in AZIMUTHS + LENGTHS]
    batch = solve_batch(integrator, problems, tol=tol, monitor=monitor)
    alone = [integrator.solve(problem, tol=tol, monitor=monitor) for problem in problems]
    assert all(same(b, a) for b, a in zip(batch, alone, strict=True))
    assert len({b.steps for b in batch}) > 1  # members take different numbers of steps


@pytest.mark.parametrize("scene", [LAB_90S, SCENES["seed_2min"]], ids=lambda scene: scene.name)
@pytest.mark.parametrize("tol", [1e-8, 1e-12])
def test_heyoka_batch_mode_equals_the_members_alone_to_round_off(scene: Scene, tol: float) -> None:
    integrator = get_integrator("heyoka_taylor")
    # more members than lanes, a partly filled last group, and two release energies (two heyoka ε)
    sweep = members(scene, release_azimuth_deg=list(np.linspace(0.0, 180.0, lanes() + 3)))
    sweep += members(scene, amplitude_m=[0.5 * scene.params.amplitude_m])
    problems = [member.problem() for member in sweep]
    batch = solve_batch(integrator, problems, tol=tol, monitor=False)
    alone = [integrator.solve(problem, tol=tol, monitor=False) for problem in problems]
    for b, a, problem in zip(batch, alone, problems, strict=True):
        assert b.status == a.status == "ok" and b.extra == a.extra and b.tolerance == a.tolerance
        assert b.steps == a.steps and b.nfev == a.nfev  # each lane steps on its own (integrators.batch_heyoka)
        assert np.max(np.abs(b.y - a.y) / state_scale(problem.params)) <= HEYOKA_BATCH_BOUND


def test_heyoka_with_events_and_quad_run_member_by_member() -> None:
    problems = [scene.problem() for scene in members(SCENES["seed_2min"], release_azimuth_deg=[0.0, 60.0])]
    for name, tol, monitor in (("heyoka_taylor", 1e-10, True), ("heyoka_taylor_quad", 1e-20, False)):
        integrator = get_integrator(name)
        batch = solve_batch(integrator, problems, tol=tol, monitor=monitor)
        assert all(same(b, integrator.solve(p, tol=tol, monitor=monitor)) for b, p in zip(batch, problems, strict=True))


def test_a_malformed_batch_is_refused() -> None:
    problem = LAB_90S.problem()
    other_model = Problem(SCENES["pantheon"].problem().model, problem.params, problem.t_out)
    other_grid = Problem(problem.model, problem.params, problem.t_out[:-1])
    integrator = get_integrator("rk4")
    step_s = 0.1 / LAB_90S.params.pendulum_frequency_rad_s
    for problems, message in (([], "at least one member"), ([problem, other_model], "member 1: model"),
                              ([problem, other_grid], "member 1: its output grid")):
        with pytest.raises(ValueError, match=message):
            solve_batch(integrator, problems, step_s=step_s)
    with pytest.raises(ValueError, match="2 step sizes for 1 members"):
        solve_batch(integrator, [problem], step_s=[step_s, step_s])
    with pytest.raises(ValueError, match="tolerance"):
        solve_batch(integrator, [problem], step_s=step_s, tol=1e-8)


def test_references_in_batch_are_the_references_alone(tmp_path, monkeypatch) -> None:
    sweep = members(dataclasses.replace(SCENES["seed_2min"], name="seed_batch"),
                    release_azimuth_deg=[0.0, 45.0, 90.0, 135.0])
    monkeypatch.setenv(CACHE_ENVIRONMENT_VARIABLE, str(tmp_path / "batch"))
    batch = references_for(sweep + sweep[:1])  # a repeated member is computed once and returned twice
    assert batch[0] is batch[-1] and len({r.y.tobytes() for r in batch}) == len(sweep)
    monkeypatch.setenv(CACHE_ENVIRONMENT_VARIABLE, str(tmp_path / "alone"))  # computed again, one by one
    for scene, in_batch in zip(sweep, batch, strict=False):
        alone = reference_for(scene)
        assert alone is not in_batch and alone.y.tobytes() == in_batch.y.tobytes()
        assert alone.precession_rate_rad_s == in_batch.precession_rate_rad_s
