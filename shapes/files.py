"""Files written beside their final name and renamed into place."""

from __future__ import annotations

import os
import secrets
from pathlib import Path


def new_temp_file(directory: Path, prefix: str, suffix: str) -> Path:
    """Create an empty, uniquely named file in ``directory`` and return its path.

    Unlike ``tempfile.mkstemp`` (mode 0600, for private files) the file gets the mode a
    user's other files get, 0666 less the umask (0644 under umask 022), because it is
    renamed into place as the user's output.
    """
    for _ in range(100):
        path = directory / f"{prefix}{secrets.token_hex(4)}{suffix}"
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return path
    raise FileExistsError(f"no free temporary name for {prefix}*{suffix} in {directory}")
