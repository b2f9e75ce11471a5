"""How the commands stop when asked to: Ctrl-C (SIGINT) and ``kill`` (SIGTERM).

:func:`terminate_as_interrupt` makes SIGTERM (``kill``, a job scheduler's stop) end a
command as Ctrl-C does, so the command's interrupt path runs: it releases its locks,
removes what it has not finished and prints what is kept and how to continue. This
module imports only the standard library.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM acts as SIGINT: it calls the SIGINT handler in effect
    when it arrives (Python's raises ``KeyboardInterrupt``; generation's asks to stop
    at the next chunk boundary), or raises ``KeyboardInterrupt`` where SIGINT is ignored
    (a background job of a non-interactive shell) or not Python's to handle. Only in the
    main thread, where Python runs signal handlers; the previous handler is put back on
    exit."""

    def interrupt(signum: int, frame: object) -> None:
        handler = signal.getsignal(signal.SIGINT)
        if callable(handler):
            handler(signal.SIGINT, frame)
        else:
            raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, interrupt)
    except ValueError:  # not the main thread
        previous = None
    try:
        yield
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
