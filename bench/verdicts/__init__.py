"""Verdicts: pure functions from a run's output (and its scene's reference) to the verdict columns of
``bench.schema``: turning points and the precession rate (``turning_points``), the columns of one run
(``columns``), and the order seen in a sweep (``convergence``)."""
