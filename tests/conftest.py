"""Shared pytest configuration."""

import os

# one BLAS thread per test process keeps timings and rounding reproducible
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
