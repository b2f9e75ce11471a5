"""The ``tactile-synth`` console script's entry point.

Loading the command-line interface imports numpy, scipy and the four packages, which
takes a noticeable moment; a Ctrl-C then lands before :func:`benchmark.cli.main` has its
error boundary in place. This wrapper imports only the standard library itself, so an
interrupt at any point of start-up ends the command with one line, as it does later.
"""

from __future__ import annotations

import sys


def main() -> int:
    try:
        from benchmark.cli import main as run

        return run()
    except KeyboardInterrupt:
        print("tactile-synth: interrupted", file=sys.stderr)
        return 130
