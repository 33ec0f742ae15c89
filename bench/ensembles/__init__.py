"""Ensembles' results: per ensemble, integrator and setting, the statistics of an error over the members."""
