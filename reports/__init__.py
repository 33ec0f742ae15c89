"""The reporting side of foucault-bench: the report folder (``build``), its charts and tables, the seed note
revisited (``seed``) and the interactive simulation (``simulate``). Modules here read plain data and plot;
the computations they show live in ``bench`` (``bench.studies``, ``bench.verdicts``)."""
