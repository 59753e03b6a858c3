"""Imported first by the timing benchmarks, before numpy: one BLAS (OpenBLAS or MKL) /
OpenMP thread unless the caller's environment says otherwise, so that timings measure the
filters rather than the thread pool (and two benchmarks on the two cores do not compete for
it)."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
