"""Shared test configuration. Fixtures stay tiny and inline; slow end-to-end tests are
marked ``@pytest.mark.slow`` (CI runs them too)."""

import os

# Keep matplotlib headless and BLAS single-threaded-deterministic in tests.
os.environ.setdefault("MPLBACKEND", "Agg")
