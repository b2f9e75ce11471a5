"""How the commands stop when asked to: Ctrl-C (SIGINT) and ``kill`` (SIGTERM).

:class:`StopRequests` turns Ctrl-C into a request that the work checks at points where
stopping is safe; :func:`terminate_as_interrupt` makes SIGTERM (``kill``, a job
scheduler's stop) end a command as Ctrl-C does, so the command's interrupt path runs: it
releases its locks, removes what it has not finished and prints what is kept and how to
continue. This module imports only the standard library.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


class StopRequests:
    """Within the block, the first Ctrl-C (SIGINT) asks to stop: :meth:`check` then
    raises ``KeyboardInterrupt`` where the caller calls it, between units of work.

    A ``KeyboardInterrupt`` raised at an arbitrary bytecode can land inside a lock's
    ``with`` block of ``concurrent.futures``, leaving the interpreter unable to exit, or
    while zarr's IO thread still writes for the interrupted call, so that its files
    reappear after the caller has removed what it wrote; a flag checked between units
    cannot. ``notice``: printed to stderr when the request arrives (e.g. what the work
    still finishes). A second Ctrl-C raises at once. Outside the main thread, or where
    SIGINT has another handler than Python's (or is ignored), this does nothing.
    """

    def __init__(self, notice: str | None = None) -> None:
        self.notice = notice
        self.requested = False
        self._previous: Any = None

    def __enter__(self) -> StopRequests:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.getsignal(signal.SIGINT)
            if self._previous is signal.default_int_handler:
                signal.signal(signal.SIGINT, self._handle)
            else:  # the caller handles SIGINT its own way: leave it alone
                self._previous = None
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        if self.notice:
            # On a terminal the notice starts a new line after a progress bar's.
            print(
                ("\n" if sys.stderr.isatty() else "") + self.notice,
                file=sys.stderr,
                flush=True,
            )

    def check(self) -> None:
        """``KeyboardInterrupt`` if a stop was asked for."""
        if self.requested:
            raise KeyboardInterrupt

    def __exit__(self, *exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


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
