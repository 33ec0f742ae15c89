"""Running a matrix: the matrix file (``matrix``), the timing protocol (``timing``), one run made a row
(``execute``), the matrix run (``runner``) on an executor (``executors``: ``local_executor``, ``dask_executor``,
in ``worker`` processes) and the results store (``store``)."""
