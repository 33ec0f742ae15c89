"""The benchmark side of foucault-bench: scenes, matrices, the runner, the results store, checks and perf."""
