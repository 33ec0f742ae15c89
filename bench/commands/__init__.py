"""Sub-commands of the foucault-bench command line."""
