"""Run a snippet in a new Python interpreter with chosen environment variables, for tests
of what happens at import time (thread pools, allocator thresholds)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_json(code: str, cleared: Iterable[str], **env: str) -> dict:
    """Run ``code`` from the repository root with the variables ``cleared`` removed from
    this environment and ``env`` set; returns the JSON it prints last."""
    drop = set(cleared)
    base = {k: v for k, v in os.environ.items() if k not in drop}
    base["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), base.get("PYTHONPATH")]))
    out = subprocess.run(
        [sys.executable, "-c", code],
        env={**base, **env},
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])
