"""One core per diagnosis case, for the suite's runners.

The thread counts of BLAS, OpenMP and numba are read when those libraries load,
so :func:`one_core` runs before numpy, scipy or numba are imported (a runner
calls it at its top when run as a script or as a worker process spawned by it;
imported as a module, by the tests, a runner leaves the process alone: numba
refuses a thread count changed late). This module imports nothing but ``os``.
"""

from __future__ import annotations

import os

#: The variables that fix a library's thread count at load time.
VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "NUMBA_NUM_THREADS",
)


def one_core() -> None:
    """Set every variable of :data:`VARIABLES` to one thread."""
    for v in VARIABLES:
        os.environ[v] = "1"
