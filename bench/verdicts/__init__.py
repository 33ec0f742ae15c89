"""Verdicts: from a run's output (and its scene's reference) to the verdict columns of ``bench.schema``: the
columns of one run (``columns``), the order seen in a sweep (``convergence``), the stability limit
(``stability``), the Pareto fronts (``pareto``); and which model a scene needs (``adequacy``, which compares the
scene's references under each model of the hierarchy)."""
