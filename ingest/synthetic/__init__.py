"""Synthetic logs with known truth, for tests, benchmarks and warming up the compiled kernels."""
