"""Tests of the fuzz harness in ``benchmarks/fuzz``."""
