"""The run summary: one line per scene × integrator of stored run rows, and the table printed from it.

Printed at the end of a matrix run (``foucault-bench run``) and by ``foucault-bench results``; plain Python over
row mappings, so that printing a summary imports no pandas.
"""

from __future__ import annotations

from typing import Any, Iterable, Mapping

from foucault_bench.bench.problems.scene_key import label_map
from foucault_bench.bench.schema import RUN_STATUSES, is_present, setting_label


def summarize(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One line per scene × integrator (sorted by both): run counts by status, the best (smallest) reference
    error among the ok runs, the setting that reached it and its cost (median CPU time of the worker thread,
    steps). A scene is its name and physics (``scene_key``): a name with two physics gives two scenes, labelled
    as ``bench.problems.scene_key.scene_labels`` does. ``rows`` are run rows as mappings
    (``ResultsStore.records``, or a frame's records); plain Python, so that printing a summary imports no
    pandas."""
    rows = list(rows)
    labels = label_map((row["scene"], row.get("scene_key")) for row in rows)
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        scene = labels[str(row["scene"]), row.get("scene_key") if isinstance(row.get("scene_key"), str) else None]
        groups.setdefault((scene, row["integrator"]), []).append(row)
    lines = []
    for (scene, integrator), group in sorted(groups.items()):
        ok = [row for row in group if row["status"] == "ok" and is_present(row["reference_error"])]
        best = min(ok, key=lambda row: row["reference_error"]) if ok else None  # the first of equal errors
        lines.append({
            "scene": scene,
            "integrator": integrator,
            "runs": len(group),
            **{status: sum(row["status"] == status for row in group) for status in RUN_STATUSES},
            "best_reference_error": None if best is None else best["reference_error"],
            "at": None if best is None else setting_label(best["kh"], best["tol"]),
            "cpu_time_s": None if best is None else best["cpu_time_s"],
            "steps": None if best is None else best["steps"],
        })
    return lines


def summary_text(rows: Iterable[Mapping[str, Any]]) -> str:
    """``summarize`` as the table printed at the end of a matrix run and by ``foucault-bench results``."""
    from tabulate import tabulate

    lines = summarize(rows)
    if not lines:
        return "no runs stored"
    return tabulate(lines, headers="keys", floatfmt=".3g", missingval="–")
