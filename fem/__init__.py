"""The shared physics core: laminate theory, plate elements, free-free modal solves,
exact frequency sensitivities and physical effects."""
import os

# The matrices here are small (a few thousand DOFs, banded): threaded BLAS only adds
# overhead, and on a loaded 2-core machine it made solves 10-40x slower.  A user who
# wants threads can set the variable before starting Python.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
