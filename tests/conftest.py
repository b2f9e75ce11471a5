"""Shared test configuration. Fixtures stay tiny and inline; slow end-to-end tests are
marked ``@pytest.mark.slow`` (CI runs them too)."""

import os

# Before any test module loads numpy or torch: thread pools sized to the CPUs this
# process may use, idle threads sleeping (so the suite keeps its pace beside other jobs).
import tactile_synth.threads  # noqa: F401

# Keep matplotlib headless.
os.environ.setdefault("MPLBACKEND", "Agg")
