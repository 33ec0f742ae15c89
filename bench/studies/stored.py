"""The stored studies: ``STUDIES`` maps a study's name (also the name of its table in the results database) to
its function and default config; ``ensure_studies`` reads the stored tables and computes the missing ones."""

from __future__ import annotations

import multiprocessing
from dataclasses import dataclass
from typing import Callable, Iterator, Protocol

import pandas as pd
from tqdm import tqdm

from foucault_bench.bench.parent_death import worker_pool
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
        # version 2: the k·h grid goes on to 6.5, so that every declared limit (composition10: 5.97) lies inside it
        Study("study_stability", stability_sweep, StabilitySweepConfig(), version=2),
        Study("study_precession_latitude", precession_vs_latitude, PrecessionLatitudeConfig()),
        # version 2: kh is the step taken (kh_requested the configured one); no rk4
        Study("study_release_azimuth", precession_vs_release_azimuth, ReleaseAzimuthConfig(), version=2),
        # version 2: composition8 and composition10 too
        Study("study_long_time_roundoff", roundoff_growth, RoundoffConfig(), version=2),
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
                   progress: bool = True, store_computed: bool = True, jobs: int = 1) -> dict[str, pd.DataFrame]:
    """Every study's table: read from ``store`` (``read_table``) or, when missing, of another ``Study.version``
    or ``recompute``, computed with its config (``configs`` overrides the defaults by study name) and written
    back (``write_table``) unless ``store_computed`` is false (a read-only database). ``store`` may be None:
    everything is computed and nothing is written. ``jobs`` > 1 computes the missing studies side by side in
    that many worker processes (forked where the platform can; each study's table is the same either way: a
    study is a deterministic computation of its config), with one progress bar over the studies."""
    configs = configs or {}
    tables: dict[str, pd.DataFrame] = {}
    for name, study in STUDIES.items():
        if store is not None and not recompute:
            try:
                stored = store.read_table(name)
            except KeyError:
                continue
            if not stored.empty and stored_version(stored) == study.version:
                tables[name] = stored
    missing = [name for name in STUDIES if name not in tables]
    for name, table in _computed(missing, configs, progress, jobs):
        table[STUDY_VERSION_COLUMN] = STUDIES[name].version
        if store is not None and store_computed:
            store.write_table(name, table)
        tables[name] = table
    return {name: tables[name] for name in STUDIES}


def _compute(name: str, config: object, progress: bool) -> tuple[str, pd.DataFrame]:
    return name, STUDIES[name].compute(config, progress=progress)


def _compute_quietly(task: tuple[str, object]) -> tuple[str, pd.DataFrame]:
    return _compute(*task, progress=False)


def _computed(names: list[str], configs: dict[str, object], progress: bool,
              jobs: int) -> Iterator[tuple[str, pd.DataFrame]]:
    """(name, table) of the studies ``names``, in this process (each with its own progress bar) or, with
    ``jobs`` > 1 and several of them, in a pool of worker processes (one bar counting the studies done)."""
    tasks = [(name, configs.get(name, STUDIES[name].config)) for name in names]
    if jobs < 2 or len(tasks) < 2 or "fork" not in multiprocessing.get_all_start_methods():
        for name, config in tasks:
            yield _compute(name, config, progress)
        return
    with worker_pool(multiprocessing.get_context("fork"), min(jobs, len(tasks))) as pool, \
            tqdm(total=len(tasks), desc="studies", unit="study", disable=not progress, leave=False) as bar:
        for name, table in pool.imap_unordered(_compute_quietly, tasks):  # as each study ends
            bar.update()
            yield name, table
