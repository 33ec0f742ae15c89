"""The accuracy gate: a thresholds file checked against stored or fresh results (``foucault-bench check``)."""
