"""Spawned sweep workers that do not run the parent's `__main__` again.

multiprocessing's spawn start method has each new process import the parent's main module
(as `__mp_main__`) before it runs anything, so that functions defined there can be
unpickled. A sweep's workers need nothing from it: they run `worker.run_task` on payloads of
plain data, with `trie.worker_init` as initializer. Importing it anyway costs each worker the
script's own imports and side effects, requires the `if __name__ == "__main__":` guard, and
fails outright where the main module has no file to import: a script read from standard
input (`python - <<EOF`), whose `__file__` is ``"<stdin>"``, left every task without a row
and printed a `FileNotFoundError` traceback per worker.

`BareSpawnContext` is the spawn context whose processes are started with a stand-in
`__main__` (no file, no module name), so multiprocessing tells them to import none, and with
single-threaded BLAS (`blas.VARIABLES` at 1 where the caller has not set them) in their
environment only: set in the caller's, they stayed there after a sweep from a notebook and
made every process it started later single-threaded.
"""

from __future__ import annotations

import os
import sys
import types
from multiprocessing.context import SpawnContext, SpawnProcess

from ..blas import VARIABLES

__all__ = ["BareSpawnContext"]


class _BareSpawnProcess(SpawnProcess):
    """A spawned process told to import no main module."""

    @staticmethod
    def _Popen(process_obj):
        # multiprocessing reads what to import from sys.modules["__main__"] while it starts
        # the process (spawn.get_preparation_data), in this thread: the stand-in is in place
        # for that moment only, and the parent's main module is back before the call returns
        # (the BLAS variables likewise: the child's environment is this process's, copied
        # as it starts; a value the caller set wins)
        main = sys.modules["__main__"]
        sys.modules["__main__"] = types.ModuleType("__main__")
        unset = [name for name in VARIABLES if name not in os.environ]
        os.environ.update(dict.fromkeys(unset, "1"))
        try:
            return SpawnProcess._Popen(process_obj)
        finally:
            sys.modules["__main__"] = main
            for name in unset:
                os.environ.pop(name, None)


class BareSpawnContext(SpawnContext):
    """multiprocessing's spawn context, its processes importing no main module."""

    Process = _BareSpawnProcess
