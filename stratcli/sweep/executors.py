"""The executors a sweep's tasks run on: a local process pool with single-threaded BLAS
(`local_executor`: forked where that is safe, else spawned) and a Dask cluster's
(`dask_executor`: its address checked, and refused at once where it cannot be reached);
`run.run_sweep` takes either, or any other `concurrent.futures.Executor`.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import sys
import threading
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from .. import blas
from ..errors import InputError, Problem
from .spawning import BareSpawnContext

__all__ = ["ExecutorInfo", "dask_executor", "local_executor"]

CONNECT_SECONDS = 20.0  # to reach a Dask scheduler and hear from it
NOT_A_SCHEDULER = (  # the hint of an address that answers, but not as a scheduler
    "a Dask scheduler listens on port 8786 by default; 8787 is its dashboard's"
)
PROBE_TIMEOUT = 5.0  # s: a host:port that refuses or does not exist fails before Client waits


@dataclass(frozen=True)
class ExecutorInfo:
    """What ran the tasks (recorded in sweep.json)."""

    kind: str  # "process-pool", "dask" or the executor's class name
    workers: int
    address: str | None = None


def local_executor(jobs: int) -> ProcessPoolExecutor:
    """A pool of `jobs` worker processes with single-threaded BLAS.

    On Linux, forked when that is safe: no other thread runs in this process, and its BLAS
    was limited to one thread before numpy loaded (`blas.limited`: the `stratplan` command
    does so first thing; a script can set the three variables before it imports numpy). A
    forked worker starts with what this process has imported, in a few milliseconds instead
    of the 0.3 s a fresh interpreter needs to import numpy, pydantic and the planner.
    Otherwise spawned: a worker imports numpy itself, after the BLAS variables are set,
    whatever threads the calling process runs (a notebook, Dask's client); it does not import
    the caller's `__main__` (`spawning`): a script read from standard input works too, and no
    script needs the `if __name__ == "__main__":` guard. Workers die with the process that
    started them and leave SIGINT to it (`trie.worker_init`).
    """
    from ..trie import worker_init

    fork = _fork_is_safe()  # (a spawned worker is given single-threaded BLAS as it starts)
    if fork:
        from .worker import preload

        preload()  # once here, instead of once in every worker
    context = multiprocessing.get_context("fork") if fork else BareSpawnContext()
    return ProcessPoolExecutor(
        max_workers=jobs, mp_context=context, initializer=worker_init, initargs=(os.getpid(),)
    )


def _fork_is_safe() -> bool:
    # not on macOS: system libraries (Accelerate) are not fork-safe, and CPython spawns there
    return sys.platform.startswith("linux") and threading.active_count() == 1 and blas.limited()


@contextmanager
def dask_executor(address: str) -> Iterator[tuple[Executor, ExecutorInfo]]:
    """A Dask cluster's executor: `address` is a scheduler address or a scheduler JSON file.

    Raises
    ------
    InputError
        Naming the argument `dask`: Dask is not installed (the `stratplan[dask]` extra), or
        the scheduler cannot be reached.
    """
    try:
        from distributed import Client
    except ImportError:
        raise _bad_dask(
            None,
            "dask.distributed is not installed (pip install 'stratplan[dask]'; in a source "
            "checkout: pip install -e '.[dask]')",
        ) from None
    if not address.strip():  # (`--dask "$SCHEDULER"` unset had planned here, without a word)
        raise _bad_dask(None, "empty: give a scheduler's address (tcp://host:8786) or its file")
    if Path(address).is_dir():
        raise _bad_dask(
            address, "a folder, not a scheduler's address (tcp://host:8786) or its JSON file"
        )
    target = address
    if address.endswith(".json") or Path(address).is_file():  # a scheduler file: its address
        try:
            target = json.loads(Path(address).read_text())["address"]
            assert isinstance(target, str)
        except (OSError, ValueError, KeyError, TypeError, AssertionError):
            raise _bad_dask(
                address, "not a readable Dask scheduler file (JSON with an address)"
            ) from None
    if (problem := _address_problem(target)) is not None:
        raise _bad_dask(address, problem)
    host_port = _tcp(target)  # None: not a host:port address (inproc://, no port)
    if host_port is not None and (refused := _unreachable(*host_port)) is not None:
        raise _bad_dask(address, f"cannot reach the scheduler ({refused})")
    client = _connected(Client, target, address, host_port is not None)
    try:
        workers = len(client.scheduler_info().get("workers", {}))
        info = ExecutorInfo("dask", workers, str(client.scheduler.address))
        yield client.get_executor(pure=False), info
    finally:
        client.close()


def _connected(Client, target: str, address: str, tcp: bool):
    """`Client(target)`, or the InputError of `address` that says why not. Made on a thread
    of its own and given `CONNECT_SECONDS`: a port that accepts connections but is not a
    scheduler's (its dashboard's, a web server's) had kept Client waiting past its own
    timeout for as long as the other end kept the connection open, and a reply that was not
    Dask's came back as numpy's "Unable to allocate 3.07 EiB" (`tcp`: the address is a
    host:port that accepted the probe's connection, so a garbled reply came from there)."""
    made: dict = {}

    def connect() -> None:
        try:
            made["client"] = Client(target, timeout=f"{CONNECT_SECONDS:g}s")
        except Exception as exc:  # whatever distributed raises for an address it cannot use
            made["error"] = exc

    thread = threading.Thread(target=connect, name="stratplan-dask-connect", daemon=True)
    thread.start()
    thread.join(CONNECT_SECONDS)
    if thread.is_alive():  # (left to end with the process: Client cannot be interrupted)
        raise _bad_dask(
            address,
            f"no Dask scheduler answered there within {CONNECT_SECONDS:g} s, though the port "
            f"accepts connections ({NOT_A_SCHEDULER})",
        )
    exc = made.get("error")
    if tcp and isinstance(exc, MemoryError | ValueError | TypeError | KeyError):  # garbled
        raise _bad_dask(address, f"it answered, but not as a Dask scheduler ({NOT_A_SCHEDULER})")
    if exc is not None:
        raise _bad_dask(address, f"cannot reach the scheduler ({exc})")
    return made["client"]


def _bad_dask(address: str | None, message: str) -> InputError:
    """The error of the `dask` argument (`--dask` on the command line: `cli.render.FLAGS`)."""
    return InputError([Problem("dask", message, given=address)])


def _address_problem(address: str) -> str | None:
    """Why `address` cannot be a scheduler's, as far as its text tells: a port that is not a
    number from 0 to 65535, or an in-process (inproc://) address, which only the process that
    made it can use. None otherwise (other mistakes are left to `Client`'s own words)."""
    from distributed.comm.addressing import parse_address

    try:
        scheme, location = parse_address(address)
    except ValueError:
        return None
    if scheme == "inproc":
        return (
            "an inproc:// address is usable only inside the process that made it; give the "
            "scheduler's tcp:// address (host:port) or its scheduler file"
        )
    if scheme not in ("tcp", "tls", "ws", "wss", "ucx"):
        return None
    if location.startswith("["):  # [IPv6]:port
        _, _, rest = location.partition("]")
        colon, port = rest[:1] == ":", rest[1:]
    else:
        _, colon, port = location.partition(":")
        colon = bool(colon) and ":" not in port  # a bare IPv6 address has no port
    if colon and not (port.isascii() and port.isdigit() and int(port) <= 65535):
        return f"invalid port {port!r} (a number from 0 to 65535)"
    return None


def _unreachable(host: str, port: int) -> str | None:
    """Why a TCP connection to a scheduler's host:port fails at once (refused, unknown host,
    no route), or None: it connects, or it did not answer within `PROBE_TIMEOUT` (an address
    that is not host:port is left to `Client`'s words). `Client` itself retries such
    failures for `CONNECT_SECONDS` before giving up; a scheduler that is up sees one
    connection closed before the handshake (logged at INFO level)."""
    import socket

    from distributed.comm.addressing import unparse_host_port

    try:
        with socket.create_connection((host, port), timeout=PROBE_TIMEOUT):
            return None
    except TimeoutError:  # slow, not refused: Client waits for it as usual
        return None
    except socket.gaierror as exc:
        return f"unknown host {host!r}: {exc.strerror}"
    except OSError as exc:  # refused, no route to the host
        reason = exc.strerror or str(exc)
        return f"{reason[:1].lower()}{reason[1:]} at {unparse_host_port(host, port)}"


def _tcp(address: str) -> tuple[str, int] | None:
    """(host, port) of a host:port address, or None (inproc://, a scheme without a port)."""
    from distributed.comm.addressing import get_address_host_port

    try:
        return get_address_host_port(address)
    except (ValueError, TypeError):
        return None
