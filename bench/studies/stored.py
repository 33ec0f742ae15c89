"""The stored studies: ``STUDIES`` maps a study's name (also the name of its table in the results database) to
its function and default config; ``ensure_studies`` reads the stored tables and computes the missing ones."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

import pandas as pd

from foucault_bench.bench.studies.energy import LongTimeEnergyConfig, long_time_energy
from foucault_bench.bench.studies.long_time_roundoff import RoundoffConfig, roundoff_growth
from foucault_bench.bench.studies.precession import (
    PrecessionLatitudeConfig, ReleaseAzimuthConfig, precession_vs_latitude, precession_vs_release_azimuth,
)
from foucault_bench.bench.studies.stability import StabilitySweepConfig, stability_sweep


@dataclass(frozen=True)
class Study:
    """A study stored as a table named ``name`` in the results database. ``version`` counts the changes to what
    its table holds (a stored table carries it in column ``study_version``; a table without it is version 1):
    a stored table of another version is recomputed, never shown as if it were the current study's."""

    name: str
    compute: Callable[..., pd.DataFrame]
    config: object
    version: int = 1


STUDY_VERSION_COLUMN = "study_version"

STUDIES: dict[str, Study] = {
    study.name: study
    for study in (
        # version 2: one representative per family from the declared facts, one tolerance for the adaptive ones
        Study("study_long_time_energy", long_time_energy, LongTimeEnergyConfig(), version=2),
        Study("study_stability", stability_sweep, StabilitySweepConfig()),
        Study("study_precession_latitude", precession_vs_latitude, PrecessionLatitudeConfig()),
        # version 2: kh is the step taken (kh_requested the configured one); no rk4
        Study("study_release_azimuth", precession_vs_release_azimuth, ReleaseAzimuthConfig(), version=2),
        Study("study_long_time_roundoff", roundoff_growth, RoundoffConfig()),
    )
}


def stored_version(table: pd.DataFrame) -> int:
    """The study version a stored table was computed by (1 when it does not say)."""
    if STUDY_VERSION_COLUMN not in table.columns or table.empty:
        return 1
    return int(table[STUDY_VERSION_COLUMN].iloc[0])


class TableStore(Protocol):
    """What ``ensure_studies`` needs of a store: ``bench.run.store.ResultsStore``'s named tables."""

    def read_table(self, name: str) -> pd.DataFrame:
        """The stored table ``name``; ``KeyError`` when there is none."""

    def write_table(self, name: str, frame: pd.DataFrame) -> None:
        """Store ``frame`` as table ``name``, replacing it."""


def ensure_studies(store: TableStore | None, recompute: bool = False, configs: dict[str, object] | None = None,
                   progress: bool = True, store_computed: bool = True) -> dict[str, pd.DataFrame]:
    """Every study's table: read from ``store`` (``read_table``) or, when missing, of another ``Study.version``
    or ``recompute``, computed with its config (``configs`` overrides the defaults by study name) and written
    back (``write_table``) unless ``store_computed`` is false (a read-only database). ``store`` may be None:
    everything is computed and nothing is written."""
    configs = configs or {}
    tables = {}
    for name, study in STUDIES.items():
        stored = None
        if store is not None and not recompute:
            try:
                stored = store.read_table(name)
            except KeyError:
                stored = None
        if stored is None or stored.empty or stored_version(stored) != study.version:
            stored = study.compute(configs.get(name, study.config), progress=progress)
            stored[STUDY_VERSION_COLUMN] = study.version
            if store is not None and store_computed:
                store.write_table(name, stored)
        tables[name] = stored
    return tables
