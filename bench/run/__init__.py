"""Running a matrix: the matrix file (``matrix``), the timing protocol (``timing``), the runner (``runner``) and the
results store (``store``)."""
