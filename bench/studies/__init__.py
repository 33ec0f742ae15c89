"""Studies behind the report's study charts: plain computations that return tidy pandas DataFrames.

Each study is one function of a frozen config dataclass (sizes are fields, so a test can run a small one) and
returns a DataFrame; ``reports`` only reads and plots these frames. One module per study (``energy``,
``stability``, ``precession``, ``seed``, ``long_time_roundoff``), what they share (``common``: running an integrator at a setting,
choosing integrators from their declared facts), and the stored ones (``stored``: ``STUDIES``,
``StudyTables``, ``ensure_studies``). This package re-exports their public names.

All runs go through the suite's own models and integrator registry; nothing here re-implements an equation of
motion or an integrator.
"""

from foucault_bench.bench.studies.common import (
    family_representatives, relative_energy_error, solve_with_setting, structure_preserving_integrators,
    study_setting_label,
)
from foucault_bench.bench.studies.energy import (
    BOUNDED_BELOW_EXPONENT, GROWING_ABOVE_EXPONENT, LongTimeEnergyConfig, energy_trends, long_time_energy,
)
from foucault_bench.bench.studies.long_time_roundoff import RoundoffConfig, roundoff_growth
from foucault_bench.bench.studies.precession import (
    MIDPOINT_INTEGRATOR, PrecessionLatitudeConfig, ReleaseAzimuthConfig, midpoint_precession_law,
    precession_vs_latitude, precession_vs_release_azimuth,
)
from foucault_bench.bench.studies.seed import (
    SeedConfig, SeedStudy, centrifugal_check, seed_revisited, seed_series, seed_study,
)
from foucault_bench.bench.studies.stability import StabilitySweepConfig, stability_sweep
from foucault_bench.bench.studies.stored import (
    STUDIES, STUDY_VERSION_COLUMN, Study, StudyTables, ensure_studies, stored_studies, stored_version,
)

__all__ = [
    "BOUNDED_BELOW_EXPONENT", "GROWING_ABOVE_EXPONENT", "LongTimeEnergyConfig", "MIDPOINT_INTEGRATOR",
    "PrecessionLatitudeConfig", "ReleaseAzimuthConfig", "RoundoffConfig", "STUDIES", "STUDY_VERSION_COLUMN", "SeedConfig", "SeedStudy",
    "StabilitySweepConfig", "Study", "StudyTables", "centrifugal_check", "energy_trends", "ensure_studies",
    "family_representatives", "long_time_energy", "midpoint_precession_law", "precession_vs_latitude",
    "precession_vs_release_azimuth", "relative_energy_error", "roundoff_growth", "seed_revisited", "seed_series", "seed_study",
    "solve_with_setting",
    "stability_sweep", "stored_studies", "stored_version", "structure_preserving_integrators", "study_setting_label",
]
