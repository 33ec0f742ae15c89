"""What wins when the forces are not conservative: from the results rows, which integrators lead on the scenes
whose model conserves no energy (drag and drive; also the seed's planar equations) against the scenes whose model
does (the ideal pendulums and the anisotropic support), and by how much the symplectic methods lose their long-time advantage there.

A symplectic one-step map conserves a modified Hamiltonian, so on a Hamiltonian model its energy error stays
bounded over exponentially long times and its phase error grows linearly, not quadratically (backward error
analysis: Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., Thms. IX.8.1 and X.3.1). With drag
or a drive the flow is not Hamiltonian and the theorem no longer applies; a symplectic method is then one
fixed-step method of its order among others. Three plain-data computations (DataFrames with the
``bench.schema`` columns in and out, as ``bench.verdicts.pareto``):

* ``leaders``: per scene and target (``reference_error`` ≤ 1e-6 and 1e-9 by default), the cheapest run meeting
  it (the leader), the cheapest run of a symplectic integrator meeting it and ``symplectic_ratio`` = its cost /
  the leader's (1 when a symplectic method leads, NaN when none meets the target);
* ``symplectic_loss``: per target, the median ``symplectic_ratio`` over the conservative and over the
  non-conservative scenes, and ``loss`` = their quotient: how many times more the cheapest symplectic method
  costs, relative to the leader, once the forces are not conservative;
* ``conservation``: per step kh, the median over one integrator's runs (default ``gauss_legendre4``) of its
  energy error on the conservative scenes and of its energy-balance residual (``bench.verdicts.energy_balance``)
  on the others: a bounded energy error becomes a residual that grows with the run.

Symplectic means the integrator's declared ``symplectic`` fact (``integrators.base``); a row of an integrator
the registry does not hold counts as not symplectic. Costs are ``cost_column``'s (CPU time where present).
"""

from __future__ import annotations

import math

import pandas as pd

from foucault_bench.bench.verdicts.pareto import cheapest_meeting, cost_column
from foucault_bench.integrators import REGISTRY, STATUS_OK

LOSS_TARGETS: tuple[float, ...] = (1e-6, 1e-9)
"""The ``reference_error`` targets the comparison is made at."""

LOSS_METRIC = "reference_error"
"""The error the targets are on: the distance from the real128 reference, defined for every model."""

CONSERVATION_INTEGRATOR = "gauss_legendre4"
"""The integrator whose conservation ``conservation`` follows (symplectic and symmetric)."""


def is_symplectic(integrator: str) -> bool:
    """The integrator's declared ``symplectic`` fact (False for a name the registry does not hold)."""
    return bool(getattr(REGISTRY.get(integrator), "symplectic", False))


def _conservative(rows: pd.DataFrame) -> bool:
    """Whether the scene's model conserves its energy, from the rows' ``energy_conserved``."""
    return bool(rows["energy_conserved"].fillna(0).astype(int).max() == 1)


def leaders(frame: pd.DataFrame, targets: tuple[float, ...] = LOSS_TARGETS,
            metric: str = LOSS_METRIC) -> pd.DataFrame:
    """One row per scene and target (the module docstring); targets no run meets are left out."""
    cost = cost_column(frame)
    rows = []
    for scene in sorted(frame["scene"].unique()):
        scene_rows = frame[frame["scene"] == scene]
        for target in targets:
            met = cheapest_meeting(scene_rows, metric, target)
            if met.empty:
                continue
            leader = met.iloc[0]
            symplectic = met[met["integrator"].map(is_symplectic)]
            row = {"scene": scene, "conservative": _conservative(scene_rows), "target": float(target),
                   "leader": leader["integrator"], "leader_setting": leader["setting"], "leader_cost_s": leader[cost],
                   "symplectic": None, "symplectic_setting": None, "symplectic_cost_s": math.nan,
                   "symplectic_ratio": math.nan}
            if not symplectic.empty:
                first = symplectic.iloc[0]
                row.update(symplectic=first["integrator"], symplectic_setting=first["setting"],
                           symplectic_cost_s=first[cost], symplectic_ratio=first[cost] / leader[cost])
            rows.append(row)
    return pd.DataFrame(rows, columns=["scene", "conservative", "target", "leader", "leader_setting", "leader_cost_s",
                                       "symplectic", "symplectic_setting", "symplectic_cost_s", "symplectic_ratio"])


def symplectic_loss(table: pd.DataFrame) -> pd.DataFrame:
    """Per target of a ``leaders`` table: the median symplectic ratio on each kind of scene and their quotient
    (NaN where a kind has no scene with a symplectic run meeting the target)."""
    rows = []
    for target, group in table.groupby("target", sort=False):
        ratios = {kind: group.loc[group["conservative"] == kind, "symplectic_ratio"].dropna() for kind in (True, False)}
        medians = {kind: float(values.median()) if not values.empty else math.nan for kind, values in ratios.items()}
        rows.append({"target": float(target), "conservative_scenes": int(ratios[True].size),
                     "conservative_median_ratio": medians[True], "nonconservative_scenes": int(ratios[False].size),
                     "nonconservative_median_ratio": medians[False],
                     "loss": medians[False] / medians[True]})
    return pd.DataFrame(rows, columns=["target", "conservative_scenes", "conservative_median_ratio",
                                       "nonconservative_scenes", "nonconservative_median_ratio", "loss"])


def conservation(frame: pd.DataFrame, integrator: str = CONSERVATION_INTEGRATOR) -> pd.DataFrame:
    """Per step of ``integrator``'s ok runs: the median energy error on conservative scenes and the median
    energy-balance residual on the others (NaN where a kind has no run at that step). Steps are grouped by kh
    to two significant digits (``kh``): the stored kh is the effective one, the matrix's rounded to a whole
    number of steps per output interval, so it differs between scenes in the third digit."""
    runs = frame[(frame["integrator"] == integrator) & (frame["status"] == STATUS_OK) & frame["kh"].notna()]
    nominal = runs["kh"].map(lambda kh: float(f"{kh:.2g}"))
    conserved = runs["energy_conserved"].fillna(0).astype(int) == 1
    rows = []
    for kh in sorted(nominal.unique(), reverse=True):
        at = nominal == kh
        energy = runs.loc[at & conserved, "energy_max_rel_error"].abs().dropna()
        balance = runs.loc[at & ~conserved, "energy_balance_max_rel_error"].abs().dropna()
        rows.append({"integrator": integrator, "kh": kh,
                     "energy_error_conservative": float(energy.median()) if not energy.empty else math.nan,
                     "energy_balance_nonconservative": float(balance.median()) if not balance.empty else math.nan})
    return pd.DataFrame(rows, columns=["integrator", "kh", "energy_error_conservative",
                                       "energy_balance_nonconservative"])


def _ratio_text(value: float, scenes: int, kind: str) -> str:
    if math.isnan(value):
        return f"no symplectic run meets it on the {kind} scenes"
    return f"the cheapest symplectic run costs {value:.3g}× the leader's on the {kind} scenes (median over {scenes})"


def summary(table: pd.DataFrame, loss: pd.DataFrame) -> str:
    """One sentence per target: who leads on the non-conservative scenes and what the cheapest symplectic run
    costs against the leader on each kind of scene."""
    sentences = []
    for row in loss.itertuples():
        leading = table[(table["target"] == row.target) & ~table["conservative"].astype(bool)]
        names = ", ".join(sorted(set(leading["leader"]))) or "no integrator"
        sentences.append(
            f"at reference error ≤ {row.target:g} the non-conservative scenes are led by {names}; "
            f"{_ratio_text(row.nonconservative_median_ratio, row.nonconservative_scenes, 'non-conservative')}, "
            f"{_ratio_text(row.conservative_median_ratio, row.conservative_scenes, 'conservative')}")
    return ("; ".join(sentences) + ".") if sentences else ""


def advise_note(runs: pd.DataFrame, target_value: float, metric: str) -> str | None:
    """For ``advise`` on a scene whose model conserves no energy: the leader at the target (on ``metric``) and
    what the cheapest symplectic method costs against it, from the scene's stored runs (None on a conservative
    scene, or when no run meets the target)."""
    if runs.empty or _conservative(runs):
        return None
    table = leaders(runs.assign(scene="scene"), (target_value,), metric)
    if table.empty:
        return None
    row = table.iloc[0]
    symplectic = ("no symplectic method meets the target" if row["symplectic"] is None else
                  f"the cheapest symplectic method, {row['symplectic']} {row['symplectic_setting']}, costs "
                  f"{row['symplectic_ratio']:.3g}× as much")
    return (f"the model conserves no energy, so the symplectic methods keep no long-time advantage: "
            f"{row['leader']} {row['leader_setting']} leads; {symplectic}")
