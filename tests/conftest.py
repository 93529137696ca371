"""Shared test set-up: single-threaded BLAS (small arrays, shared 2-core machine)."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
