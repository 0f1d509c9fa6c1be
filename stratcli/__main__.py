"""Entry point of `stratplan` and `python -m stratcli`.

Interrupts. SIGINT (Ctrl-C) and SIGTERM are taken over on the first line of `main`, before
any heavy import: the handler raises `Interrupted`, a `BaseException` that no
`except Exception` swallows and that typer does not turn into a silent exit. It unwinds
every `finally` (a half-written run directory is removed, worker processes are stopped),
then `main` prints one line, `interrupted` (SIGINT) or `terminated` (SIGTERM), and exits
128 + the signal number: 130 for Ctrl-C, 143 for SIGTERM. A record this process finished
before the signal gets `"interrupted": true` and that exit code in its manifest.json. A second
signal while unwinding leaves at once, with the same line and code; the same signal within
0.2 s of the first is the same interrupt delivered twice (`timeout -s INT` signals the command
and then its process group) and is let be. A signal the process
was started ignoring (`nohup`, `cmd &` in a script) stays ignored. A signal whose exception
Python had to drop (it arrived inside a finaliser) is picked up by `stratcli.interrupts`.

A reader that leaves early (`stratplan runs | head -1`) ends the output, not the command:
what is left to print goes nowhere, the work (a record being written) finishes, and the exit
code is the command's own, with no traceback or "Broken pipe" message.

Memory. A command runs with Python's cyclic garbage collector paused (`gc.disable`): its
passes over the ~400,000 objects that importing numpy, pydantic and matplotlib creates were
4 % of `stratplan plan`'s CPU time, and a plan makes almost no cyclic garbage (peak memory of
Sim 4 D, of the auto-mode search and of the 11 s obstacle search alike within 1 %, with and
without it). `stratplan sweep`, which runs for hours, switches it back on. The console
script (`entry`) then leaves without tearing the interpreter down: exit handlers run and
output is flushed, but the teardown of every module object (0.05 s of CPU) is skipped.
Matplotlib loads without its docstrings (`stratcli.lean_imports`: 0.08 s of a plan's CPU).
"""

import atexit
import gc
import logging
import os
import signal
import sys
import threading

from . import blas, lean_imports
from .interrupts import Interrupted, echoed, install, pending, raised

HANDLED = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}


_state = {"done": False}


class ClosedPipeSafe:
    """`sys.stdout` whose reader may leave, or whose file may fill up: from the first broken
    pipe or failed write on, output goes to /dev/null (the descriptor itself is redirected, so
    the final flush succeeds too) and the work goes on. A failed write (not a reader that
    left) is kept in `failed`, for `entry` to report."""

    def __init__(self, stream) -> None:
        self._stream = stream
        self.failed: OSError | None = None

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except OSError as exc:
            self._lost(exc)
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except OSError as exc:
            self._lost(exc)

    def _lost(self, exc: OSError) -> None:
        if not isinstance(exc, BrokenPipeError) and self.failed is None:
            self.failed = exc
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, self._stream.fileno())
        finally:
            os.close(devnull)
        try:  # what was buffered for the old file is dropped with it
            self._stream.flush()
        except OSError:
            pass

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def _on_signal(signum: int, frame) -> None:
    if _state["done"]:  # the command has finished (exit, atexit): no stack left to unwind
        _finish_interrupted(signum)
    if echoed(signum):  # the same interrupt delivered twice (to the process, its group)
        return
    if raised(signum):  # a second signal while unwinding: stop now
        _leave(signum)
    raise Interrupted(signum)  # (caught by code that goes on: `checkpoint` raises it again)


def _leave(signum: int, kept: str = "") -> None:
    try:
        os.write(2, f"{HANDLED.get(signum, 'interrupted')}{kept}\n".encode())
    finally:
        os._exit(128 + signum)


def _finish_interrupted(signum: int) -> None:
    """Mark the records already written as interrupted, print one line, exit 128 + signum."""
    for sig in HANDLED:  # nothing below may be interrupted again
        signal.signal(sig, signal.SIG_IGN)
    rundir = sys.modules.get("stratcli.records.rundir")  # not imported: nothing was written
    mark = getattr(rundir, "mark_interrupted", None)
    marked = mark(128 + signum, signal.Signals(signum).name) if mark is not None else []
    kept = ""  # a record completed before the signal: where it is (its table was not shown)
    if len(marked) == 1:
        kept = f"; the record written before it is kept: {marked[0].parent}"
    elif marked:
        kept = f"; the {len(marked)} records written before it are kept"
    _flush(sys.stdout)
    _leave(signum, kept)


def main() -> None:
    """Run the `stratplan` command line, exiting 128 + signal number on SIGINT or SIGTERM."""
    gc.disable()  # see the module's docstring
    lean_imports.install()
    for sig in HANDLED:
        if signal.getsignal(sig) is not signal.SIG_IGN:  # e.g. `nohup`, or `cmd &` in a script
            signal.signal(sig, _on_signal)
    install()  # an Interrupted raised inside a finaliser is kept, not printed and lost
    for stream in (sys.stdout, sys.stderr):  # an ASCII terminal (PYTHONIOENCODING=ascii):
        if stream is not None and hasattr(stream, "reconfigure"):  # "?" for "·", no crash
            stream.reconfigure(errors="replace")  # after the record was written, exit 1
    if sys.stdout is not None:
        sys.stdout = ClosedPipeSafe(sys.stdout)
    # matplotlib's warnings of an unwritable config or cache directory (a read-only HOME):
    # two lines on every run, even with --quiet, about a cache it makes elsewhere itself
    logging.getLogger("matplotlib").setLevel(logging.ERROR)
    try:
        blas.single_threaded()  # before numpy loads (stratcli.blas)
        from .cli import app

        try:
            app(prog_name="stratplan")
        finally:
            if pending() is not None:  # swallowed, and no checkpoint came before the end
                _finish_interrupted(pending())
    except Interrupted as exc:
        _finish_interrupted(exc.signum)
    except KeyboardInterrupt:  # raised by hand somewhere (or a handler reset by a library)
        _finish_interrupted(signal.SIGINT)
    except PermissionError as exc:  # a path the user named that cannot be searched or read
        _flush(sys.stdout)  # (a record that cannot be written is RecordError: exit 4)
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"error: {where}permission denied", file=sys.stderr)
        raise SystemExit(2) from None
    except Exception as exc:  # an Interrupted that Python wrapped on its way
        signum = _wrapped_interrupt(exc)
        if signum is None:
            raise
        _finish_interrupted(signum)
    finally:
        _state["done"] = True


def _wrapped_interrupt(exc: BaseException) -> int | None:
    """The signal of an `Interrupted` that caused `exc`, or None: Python 3.11 turns an
    exception raised while a class is made (a pydantic model's `__set_name__`, during an
    import) into "RuntimeError: Error calling __set_name__ ...", a Ctrl-C there a traceback."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, Interrupted):
            return exc.signum
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def entry() -> None:
    """The console script: `main`, then a quick exit (see the module's docstring)."""
    try:
        main()
    except SystemExit as exc:
        _leave_quickly(exc.code)
    _leave_quickly(0)


def _leave_quickly(code) -> None:
    """Exit with `code` after the exit handlers, without the interpreter's teardown."""
    others = [t for t in threading.enumerate() if t is not threading.main_thread()]
    if not (code is None or isinstance(code, int)) or any(not t.daemon for t in others):
        raise SystemExit(code)  # a message to print, or threads to join: the usual way
    atexit._run_exitfuncs()  # weakref finalisers, temporary directories, ...
    code = code or 0
    _flush(sys.stdout)
    failed = getattr(sys.stdout, "failed", None)  # a full disk, say (ClosedPipeSafe)
    if failed is not None:
        try:
            os.write(2, f"error: cannot write the output: {failed.strerror or failed}\n".encode())
        except OSError:  # no stderr either
            pass
        code = code or 120  # what Python itself exits with when its last flush fails
    _flush(sys.stderr)
    os._exit(code)


def _flush(stream) -> None:
    """Flush `stream`; None where the command was started with it closed (`>&-`)."""
    if stream is None:
        return
    try:
        stream.flush()
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    entry()
