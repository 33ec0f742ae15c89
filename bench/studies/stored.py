"""The stored studies: ``STUDIES`` maps a study's name (also the name of its table in the results database) to
its function and default config; ``StudyTables`` reads the stored tables and computes the missing ones (in worker
processes while its caller goes on), ``ensure_studies`` waits for them all."""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import queue
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Protocol

import pandas as pd
from tqdm import tqdm

from foucault_bench.bench.parent_death import outcome, stop_pools, worker_pool
from foucault_bench.bench.studies.energy import LongTimeEnergyConfig, long_time_energy, long_time_energy_parts
from foucault_bench.bench.studies.long_time_roundoff import RoundoffConfig, roundoff_growth, roundoff_growth_parts
from foucault_bench.bench.studies.precession import (
    PrecessionLatitudeConfig, ReleaseAzimuthConfig, precession_vs_latitude, precession_vs_release_azimuth,
    release_azimuth_parts,
)
from foucault_bench.bench.studies.seed import SeedConfig, seed_series
from foucault_bench.bench.studies.stability import StabilitySweepConfig, stability_sweep, stability_sweep_parts


@dataclass(frozen=True)
class Study:
    """A study stored as a table named ``name`` in the results database. ``version`` counts the changes to what
    its table holds (a stored table carries it in column ``study_version``; a table without it is version 1):
    a stored table of another version is recomputed, never shown as if it were the current study's.

    ``parts`` (optional) splits a config into smaller configs whose tables, concatenated in order, are the whole
    config's table row for row and bit for bit (``tests/test_studies.py`` checks it for every study that has
    one): the pieces that ``StudyTables`` hands to its worker processes, so that two workers share a study."""

    name: str
    compute: Callable[..., pd.DataFrame]
    config: object
    version: int = 1
    parts: Callable[[Any], list[Any]] | None = None

    def split(self, config: object) -> list[object]:
        """``parts(config)``, or ``[config]`` for a study that is computed whole."""
        return [config] if self.parts is None else self.parts(config)


STUDY_VERSION_COLUMN = "study_version"

STUDIES: dict[str, Study] = {
    study.name: study
    for study in (
        # In the order the worker processes of ``StudyTables`` take the studies' parts: the longest study first, so
        # that the last part to end is a short one (CPU of each default config, one process, 2-core AMD EPYC,
        # 2026-12-05: round-off 8.0 s, stability 4.4 s, seed 0.3 s or 5 s compiling the seed model's loops on a
        # new machine (the main job never runs that model), release azimuth 2.3 s, energy 1.3 s, latitude 0.6 s;
        # the longest single part is composition10's round-off, 3.7 s).
        # version 2: composition8 and composition10 too
        Study("study_long_time_roundoff", roundoff_growth, RoundoffConfig(), version=2, parts=roundoff_growth_parts),
        # the seed note revisited (reports.seed draws it)
        Study("study_seed", seed_series, SeedConfig()),
        # version 2: the k·h grid goes on to 6.5, so that every declared limit (composition10: 5.97) lies inside it
        Study("study_stability", stability_sweep, StabilitySweepConfig(), version=2, parts=stability_sweep_parts),
        # version 2: kh is the step taken (kh_requested the configured one); no rk4
        Study("study_release_azimuth", precession_vs_release_azimuth, ReleaseAzimuthConfig(), version=2,
              parts=release_azimuth_parts),
        # version 2: one representative per family from the declared facts, one tolerance for the adaptive ones
        Study("study_long_time_energy", long_time_energy, LongTimeEnergyConfig(), version=2,
              parts=long_time_energy_parts),
        Study("study_precession_latitude", precession_vs_latitude, PrecessionLatitudeConfig()),
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


def stored_studies(store: TableStore | None, recompute: bool = False) -> dict[str, pd.DataFrame]:
    """The studies' tables that ``store`` holds at their current ``Study.version`` (none with ``recompute``, or
    without a store): those ``StudyTables`` reads instead of computing."""
    tables: dict[str, pd.DataFrame] = {}
    if store is None or recompute:
        return tables
    for name, study in STUDIES.items():
        try:
            stored = store.read_table(name)
        except KeyError:
            continue
        if not stored.empty and stored_version(stored) == study.version:
            tables[name] = stored
    return tables


def ensure_studies(store: TableStore | None, recompute: bool = False, configs: dict[str, object] | None = None,
                   progress: bool = True, store_computed: bool = True, jobs: int = 1) -> dict[str, pd.DataFrame]:
    """Every study's table (``StudyTables``, waited for): read from ``store`` or computed, and stored."""
    with StudyTables(store, recompute, configs, progress, store_computed, jobs) as tables:
        return dict(tables)


class StudyTables(Mapping[str, pd.DataFrame]):
    """Every study's table by name, in ``STUDIES`` order: read from ``store`` (``read_table``) or, when missing, of
    another ``Study.version`` or ``recompute``, computed with its config (``configs`` overrides the defaults by
    study name) and written back (``write_table``) unless ``store_computed`` is false (a read-only database).
    ``store`` may be None: everything is computed and nothing is written.

    With ``jobs`` < 2 the missing studies are computed here and now, each with its own progress bar. With more,
    their parts (``Study.split``) go at once to that many worker processes (forked where the platform can), with
    one progress bar counting the parts as they end, and the caller goes on with other work meanwhile: looking a
    table up waits for its parts and stores each study that is complete by then. A study's table is the same
    either way: a study is a deterministic computation of its config, and its parts' tables make up its own.
    Leaving the ``with`` block (or ``close``) stops the workers, so that a failed report leaves none behind."""

    def __init__(self, store: TableStore | None, recompute: bool = False, configs: dict[str, object] | None = None,
                 progress: bool = True, store_computed: bool = True, jobs: int = 1) -> None:
        configs = configs or {}
        self._store = store if store_computed else None
        self._progress = progress
        self._tables = stored_studies(store, recompute)
        missing = [(name, configs.get(name, STUDIES[name].config)) for name in STUDIES if name not in self._tables]
        tasks = [(name, index, part)
                 for name, config in missing for index, part in enumerate(STUDIES[name].split(config))]
        self._pieces: dict[str, dict[int, pd.DataFrame]] = {name: {} for name, _ in missing}
        self._counts = Counter(name for name, _, _ in tasks)
        self._pool: concurrent.futures.ProcessPoolExecutor | None = None
        self._futures: list[concurrent.futures.Future] = []
        self._arrived: queue.SimpleQueue[tuple[str, int, pd.DataFrame] | BaseException] = queue.SimpleQueue()
        self._bar: tqdm | None = None
        if jobs < 2 or len(tasks) < 2 or "fork" not in multiprocessing.get_all_start_methods():
            for name, config in missing:
                self._add(name, STUDIES[name].compute(config, progress=progress))
            return
        self._pool = worker_pool(multiprocessing.get_context("fork"), min(jobs, len(tasks)))
        self._bar = tqdm(total=len(tasks), desc="studies", unit="part", disable=not progress, leave=False)
        try:
            for task in tasks:  # started in this order
                self._futures.append(self._pool.submit(_compute_part, task))
                self._futures[-1].add_done_callback(self._arrive)
        except BaseException:  # a Ctrl-C among the submits: the parts queued so far are cancelled
            self.close()
            raise

    def __getitem__(self, name: str) -> pd.DataFrame:
        if name not in STUDIES:
            raise KeyError(name)
        if name not in self._tables:
            self._wait_for(name)
        return self._tables[name]

    def __iter__(self) -> Iterator[str]:
        return iter(STUDIES)

    def __len__(self) -> int:
        return len(STUDIES)

    def __enter__(self) -> StudyTables:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop the worker processes (tables not yet computed stay missing): the parts not yet started are
        cancelled, and this returns when the running ones have ended (``bench.parent_death.stop_pools``)."""
        if self._pool is not None:
            pool, futures, self._pool, self._futures = self._pool, self._futures, None, []
            stop_pools([(pool, futures)])
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def _arrive(self, future: concurrent.futures.Future) -> None:
        """A part's table (or its error), in the pool's thread that receives results: counted on the bar, queued
        for this one."""
        if future.cancelled():
            return
        arrived = outcome(future)
        self._arrived.put(arrived)  # first: a failing bar cannot lose it
        if not isinstance(arrived, BaseException) and self._bar is not None:
            self._bar.update()

    def _add(self, name: str, table: pd.DataFrame) -> None:
        table[STUDY_VERSION_COLUMN] = STUDIES[name].version
        if self._store is not None:
            self._store.write_table(name, table)
        self._tables[name] = table

    def _wait_for(self, name: str) -> None:
        if self._pool is None:
            raise RuntimeError(f"study {name} was not computed: its worker processes were stopped")
        while name not in self._tables:
            arrived = self._arrived.get()
            if isinstance(arrived, BaseException):
                raise arrived
            study, index, table = arrived
            pieces = self._pieces[study]
            pieces[index] = table
            if len(pieces) == self._counts[study]:
                self._add(study, pd.concat([pieces[i] for i in range(len(pieces))], ignore_index=True))
        if all(study in self._tables for study in self._pieces):  # every part in: the workers have nothing left
            self.close()


def _compute_part(task: tuple[str, int, object]) -> tuple[str, int, pd.DataFrame]:
    name, index, config = task
    return name, index, STUDIES[name].compute(config, progress=False)
