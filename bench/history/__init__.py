"""Accuracy and cost across code versions: revisions in commit order, changes that respect noise, bisection.

``revisions`` orders a database's matrix runs by the code that made them, ``changes`` lines their rows up and
finds what changed between consecutive revisions (``foucault-bench history``, ``check --baseline``), and
``bisect`` runs one configuration at revisions of a git repository to find the first commit that changed it.
"""
