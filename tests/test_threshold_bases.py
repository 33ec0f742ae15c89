"""The built-in thresholds' bases that quote the measurement floor of a precession rate
(``bench.problems.turning_points.rate_measurement_floor``) quote what it computes for their scene, and every such
bound lies above that floor: a bound below it would fail an exact integrator for the grid's error."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.bench.problems.turning_points import rate_measurement_floor

THRESHOLDS = Path(__file__).resolve().parents[1] / "bench" / "thresholds" / "default.toml"
FLOOR_CITED = re.compile(r"floor ([0-9.]+e-?[0-9]+) on this scene, bench\.problems\.turning_points\.rate_measurement_floor")


def bounds_citing_the_floor() -> list[dict]:
    bounds = tomllib.loads(THRESHOLDS.read_text(encoding="utf-8"))["bound"]
    return [bound for bound in bounds if "rate_measurement_floor" in bound.get("basis", "")]


def test_some_bound_cites_the_floor() -> None:
    assert bounds_citing_the_floor(), "integrators/README.md says the thresholds use rate_measurement_floor"


@pytest.mark.parametrize("bound", bounds_citing_the_floor(), ids=lambda bound: f"{bound['scene']}-{bound['integrator']}")
def test_the_quoted_floor_is_the_computed_one_and_the_bound_lies_above_it(bound: dict) -> None:
    match = FLOOR_CITED.search(bound["basis"])
    assert match, bound["basis"]
    assert bound["column"].endswith("_earth"), bound["column"]  # the floor below is relative to Ω_E
    scene = SCENES[bound["scene"]]
    floor = rate_measurement_floor(scene.params, scene.output_interval_s, scene.duration_s) / scene.params.earth_rate_rad_s
    quoted = float(match.group(1))
    digits = len(match.group(1).split("e")[0].replace(".", "").lstrip("0"))
    assert f"{floor:.{digits - 1}e}" == f"{quoted:.{digits - 1}e}", (floor, quoted)
    assert bound["max"] > floor
