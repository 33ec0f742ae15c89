"""The ensemble summary: per ensemble, integrator and setting, an error's median, 90th percentile and worst value
over the members, and which member is worst; plain data computed from the member rows.

A member's rows carry ``ensemble``, ``ensemble_member`` (its swept values, JSON) and ``ensemble_setting`` (the
setting the matrix asked for; ``bench.schema``). ``ensemble_summary`` groups the rows of one matrix run by those,
and over the members whose error is a finite number (a run that failed or diverged has none: ``missing``
counts them) takes the median, the 90th percentile (linear interpolation between order statistics, numpy's
default: Hyndman & Fan's definition 7, Am. Stat. 50, 361, 1996) and the largest value, naming the member that has
it (the first in member order when two share it). ``worst_rows`` gives, per integrator and setting, the row of
that member: what ``advise --worst`` ranks and the report's worst-member chart draws; ``median_rows`` likewise
gives the row whose error is nearest the median from above (the median of an even count is between two members).
"""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

GROUP_COLUMNS = ("ensemble", "integrator", "ensemble_setting")
PERCENTILE = 90.0
SUMMARY_METRICS = ("reference_error", "precession_rate_ref_error_earth")
"""The errors ``results`` summarizes per ensemble (the report draws every metric of its charts)."""
SUMMARY_COLUMNS = ("ensemble", "integrator", "setting", "members", "missing", "median", "p90", "worst",
                   "worst_member")


def member_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """The rows of ensemble members, in their stored order (``ensemble`` present)."""
    if "ensemble" not in frame.columns:
        return frame.iloc[0:0]
    return frame[frame["ensemble"].notna()]


def single_scene_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """The rows of scenes of their own (no ensemble member), in their stored order: the per-scene sections' rows
    (an ensemble's members are shown together, per ensemble)."""
    if "ensemble" not in frame.columns:
        return frame
    return frame[frame["ensemble"].isna()]


def member_label(row: pd.Series) -> str:
    """A member as the summary names it: its scene name and swept values (``lab_3m_azimuths.az45``)."""
    return str(row["scene"])


def _groups(frame: pd.DataFrame):
    """(ensemble, integrator, setting) → the member rows (in stored order), sorted by the three."""
    members = member_rows(frame)
    for key, group in members.groupby(list(GROUP_COLUMNS), sort=True, dropna=False):
        yield key, group


def _finite(group: pd.DataFrame, metric: str) -> pd.DataFrame:
    """The member rows of ``group`` whose ``metric`` is a finite number (none for a failed run)."""
    import numpy as np
    import pandas as pd

    values = pd.to_numeric(group[metric], errors="coerce").to_numpy(dtype=float)
    return group[np.isfinite(values)]


def ensemble_summary(frame: pd.DataFrame, metric: str) -> pd.DataFrame:
    """One row per (ensemble, integrator, setting) of ``frame`` (run rows of one matrix run): ``SUMMARY_COLUMNS``
    for the error column ``metric``; median, p90 and worst NaN (and worst_member "") when no member has a
    value."""
    import numpy as np
    import pandas as pd

    records = []
    for (ensemble, integrator, setting), group in _groups(frame):
        good = _finite(group, metric)
        values = good[metric].to_numpy(dtype=float)
        worst_index = int(np.argmax(values)) if len(values) else -1
        records.append({
            "ensemble": ensemble, "integrator": integrator, "setting": setting,
            "members": len(group), "missing": len(group) - len(good),
            "median": float(np.median(values)) if len(values) else math.nan,
            "p90": float(np.percentile(values, PERCENTILE)) if len(values) else math.nan,
            "worst": float(values[worst_index]) if len(values) else math.nan,
            "worst_member": member_label(good.iloc[worst_index]) if len(values) else "",
        })
    return pd.DataFrame.from_records(records, columns=list(SUMMARY_COLUMNS))


def _picked_rows(frame: pd.DataFrame, metric: str, pick) -> pd.DataFrame:
    import pandas as pd

    picked = []
    for _, group in _groups(frame):
        good = _finite(group, metric)
        if len(good):
            picked.append(good.iloc[pick(good[metric].to_numpy(dtype=float))])
    return pd.DataFrame(picked, columns=frame.columns)


def worst_rows(frame: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Per (ensemble, integrator, setting), the row of the member with the largest finite ``metric``."""
    import numpy as np

    return _picked_rows(frame, metric, lambda values: int(np.argmax(values)))


def median_rows(frame: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Per (ensemble, integrator, setting), the row of the member whose ``metric`` is the smallest at or above
    the median (the median itself when the count is odd)."""
    import numpy as np

    def pick(values):
        median = np.median(values)
        return int(np.argmin(np.where(values >= median, values, np.inf)))

    return _picked_rows(frame, metric, pick)


def swept_values(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame``'s member rows with one column per swept field (from ``ensemble_member``)."""
    import pandas as pd

    members = member_rows(frame)
    values = pd.DataFrame([json.loads(text) for text in members["ensemble_member"]], index=members.index)
    return members.join(values)


def summary_text(frame: pd.DataFrame, metric: str) -> str:
    """The summary as the ``results`` command prints it (empty when no row is an ensemble member)."""
    table = ensemble_summary(frame, metric)
    if table.empty:
        return ""
    return f"ensembles ({metric} over the members):\n" + table.to_string(index=False, na_rep="–", float_format="{:.3g}".format)
