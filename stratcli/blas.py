"""Single-threaded BLAS, and whether this process has it.

Planning multiplies matrices of a few dozen rows, where BLAS threads only add overhead and
take the cores that worker processes need (Sim 4 energy comparison on 2 processes: 7.4 s with
OpenBLAS threads, 6.7 s without, and a third less CPU time on one). The variables below only
act when numpy is first imported, so a value set later changes nothing in this process; a
value the user set wins. `limited()` says whether this process's BLAS runs one thread, which
a worker forked from it inherits (`sweep.local_executor`).
This module imports nothing heavy: the command line calls it before numpy loads.
"""

from __future__ import annotations

import os
import sys

__all__ = ["VARIABLES", "limited", "single_threaded"]

VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

_state = {"limited": False}


def _note() -> None:
    """Remember a single-threaded BLAS: numpy not loaded yet and every variable 1."""
    if "numpy" not in sys.modules and all(os.environ.get(v) == "1" for v in VARIABLES):
        _state["limited"] = True


def single_threaded() -> None:
    """Set the variables to 1 where the user has not set them (for numpy loaded from now on:
    this process's if it has not loaded numpy yet, and every process it starts)."""
    for var in VARIABLES:
        os.environ.setdefault(var, "1")
    _note()


def limited() -> bool:
    """Whether numpy in this process runs (or, not loaded yet, will run) single-threaded BLAS.

    Asked of OpenBLAS itself where it can be found (Linux: the library numpy loaded, in
    /proc/self/maps); otherwise whether the variables were all 1 before numpy loaded."""
    _note()
    if "numpy" in sys.modules:
        threads = _openblas_threads()
        if threads is not None:
            return threads == 1
    return _state["limited"]


_GETTERS = (
    "openblas_get_num_threads",
    "openblas_get_num_threads64_",
    "scipy_openblas_get_num_threads",
    "scipy_openblas_get_num_threads64_",
)


def _openblas_threads() -> int | None:
    """The thread count of the OpenBLAS this process has loaded, or None if not found."""
    try:
        with open("/proc/self/maps") as fh:
            paths = {line.split()[-1] for line in fh if "openblas" in line.lower()}
    except OSError:
        return None
    import ctypes

    for path in sorted(paths):
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        for name in _GETTERS:
            getter = getattr(library, name, None)
            if getter is not None:
                return int(getter())
    return None


_note()  # e.g. variables set in the shell, or by a script before it imported stratcli
