"""Test-session settings shared by every test module.

One BLAS thread per process, as ``fogbench`` itself sets (``fogbench/cli/__init__.py``): ``make test``
runs the tests in two pytest-xdist workers, and OpenBLAS's threads on top of them made the
network fits 2-4x slower on a 2-core machine (tests/device/test_device.py's thermal fit: 26 s against
9 s). Set here, before any test module imports numpy; a value the caller set is kept.
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

