"""Interrupts that survive places where Python cannot raise them.

The `stratplan` entry point turns SIGINT and SIGTERM into `Interrupted`, raised from the
signal handler wherever the main thread happens to be. Python runs signal handlers between
byte codes, which includes finalisers and weak-reference callbacks (a `ProcessPoolExecutor`
keeps one): an exception raised there is reported as "Exception ignored in ..." and then
dropped, and the command would carry on as if nothing had happened. `install` replaces
`sys.unraisablehook` so that such a swallowed `Interrupted` is remembered instead of printed,
and `checkpoint` re-raises it; the engine calls `checkpoint` where work is handed out or
collected, and before anything is written, and the entry point calls it once more at the end.
The handler also notes each `Interrupted` it raises (`raised`): code that runs on after it
was raised caught it somewhere (a library's bare `except:`; every `except BaseException` of
stratplan's re-raises), so `checkpoint` raises it again there too.
Outside the command line nothing is installed and `checkpoint` costs two list tests.
"""

import signal
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

_swallowed: list[int] = []
_raised: list[int] = []  # signals whose `Interrupted` the handler raised (`raised`)
_last = [0.0]  # when (time.monotonic) the handler last raised one
ECHO = 0.2  # s: the same signal again this soon is the same interrupt (`echoed`)


class Interrupted(BaseException):
    """A handled signal arrived (`signum`); unwinds to the entry point."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _hook(unraisable) -> None:
    if isinstance(unraisable.exc_value, Interrupted):
        _swallowed.append(unraisable.exc_value.signum)
        return
    _previous(unraisable)


_previous = sys.unraisablehook


def install() -> None:
    """Remember an `Interrupted` that Python could not raise instead of printing it."""
    global _previous
    if sys.unraisablehook is not _hook:
        _previous = sys.unraisablehook
        sys.unraisablehook = _hook


def raised(signum: int) -> bool:
    """Note that the signal handler raises `Interrupted` for `signum` (the entry point's);
    whether it had raised one before (a second signal while unwinding)."""
    _raised.append(signum)
    _last[0] = time.monotonic()
    return len(_raised) > 1


def echoed(signum: int) -> bool:
    """Whether `signum` arrives within `ECHO` of the same signal the handler raised for: one
    interrupt delivered twice (`timeout -s INT` signals the command, then its process group),
    not a second one asking to leave at once (which skipped the sweep's --resume line and
    left its lock behind)."""
    return bool(_raised) and _raised[-1] == signum and time.monotonic() - _last[0] < ECHO


def pending() -> int | None:
    """The signal number of a swallowed interrupt (or of one raised), or None."""
    if _swallowed:
        return _swallowed[0]
    return _raised[0] if _raised else None


def checkpoint() -> None:
    """Raise `Interrupted` again if a signal handler's exception was swallowed (dropped by
    Python in a finaliser, or caught by code that went on)."""
    signum = pending()
    if signum is not None:
        raise Interrupted(signum)


@contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM wait until the block is done (delivered right after it). A process
    forked inside the block starts with them held too: it unblocks them (`release_signals`)
    once its own handlers are set, so that none reaches the handlers it inherited."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not on POSIX
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def release_signals() -> None:
    """In a process forked inside `signals_held`: let SIGINT and SIGTERM in again."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
