"""Process-wide settings shared by every tactile-synth package.

This package sits to the left of ``shapes``, ``synth``, ``models`` and ``benchmark``, so
all four may import it. It imports only the standard library, so importing it first
(each package's ``__init__`` does) is cheap and happens before numpy, scipy,
scikit-learn or torch load their thread pools (see :mod:`tactile_synth.threads`) or
allocate memory (see :mod:`tactile_synth.allocator`).
"""

from . import allocator, threads

__all__ = ["allocator", "threads"]
