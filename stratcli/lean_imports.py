"""Matplotlib loaded without its docstrings, in the `stratplan` process only.

Importing matplotlib writes docstrings at import time: every artist class gets a generated
`set()` signature and a table of its properties, found by introspecting its setters'
docstrings, and many docstrings are interpolated. That was about 0.1 s of the 0.5 s CPU that
`import matplotlib.figure` takes, for text nobody reads while the command draws its figures.
Python's `-OO` skips it (the docstrings are None) and matplotlib supports running so, but the
flag is process-wide and would empty stratplan's own `--help`. `install()` does it for
matplotlib's modules alone: they load from bytecode compiled at optimisation level 2 (the
`*.opt-2.pyc` beside the usual cache, the file `python -OO` itself uses and validates the
same way: by the source's modification time and size).

Nothing changes where that cache cannot be kept: with bytecode writing switched off
(`PYTHONDONTWRITEBYTECODE`, `-B`) or an unwritable package directory, a module whose
optimised bytecode is not already there is imported the usual way. The library never calls
this; `stratcli.__main__` does, before anything imports matplotlib.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import marshal
import os
import sys

__all__ = ["install"]

PACKAGES = ("matplotlib", "mpl_toolkits")


def install() -> None:
    """Load matplotlib's modules without docstrings from now on (idempotent)."""
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.insert(0, _Finder())


def _cache(source: str) -> str:
    return importlib.util.cache_from_source(source, optimization=2)


def _header(source: str) -> bytes:
    """The 16-byte header of a timestamp-validated .pyc of `source` (PEP 552)."""
    st = os.stat(source)
    mtime = (int(st.st_mtime) & 0xFFFFFFFF).to_bytes(4, "little")
    size = (st.st_size & 0xFFFFFFFF).to_bytes(4, "little")
    return importlib.util.MAGIC_NUMBER + b"\0\0\0\0" + mtime + size


class _Finder:
    """A meta path finder that hands matplotlib's source modules to `_Loader`."""

    def find_spec(self, name: str, path=None, target=None):
        if name.partition(".")[0] not in PACKAGES:
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path, target)
        loader = getattr(spec, "loader", None)
        if type(loader) is not importlib.machinery.SourceFileLoader:
            return spec  # an extension module, a namespace package, a zip: as usual
        cache = _cache(loader.path)
        if not (os.path.exists(cache) or _writable(cache)):
            return spec
        spec.loader = _Loader(loader.name, loader.path)
        return spec

    def invalidate_caches(self) -> None:  # importlib.invalidate_caches() calls every finder
        pass


def _writable(cache: str) -> bool:
    if sys.dont_write_bytecode:
        return False
    folder = os.path.dirname(cache)  # __pycache__, or the package directory that would hold it
    return os.access(folder if os.path.isdir(folder) else os.path.dirname(folder), os.W_OK)


class _Loader(importlib.machinery.SourceFileLoader):
    """Loads a module's optimisation-level-2 bytecode, writing it on first use."""

    def get_code(self, fullname: str):
        source = self.get_filename(fullname)
        cache, header = _cache(source), _header(source)
        try:
            with open(cache, "rb") as fh:
                data = fh.read()
            if data[:16] == header:
                return marshal.loads(data[16:])
        except (OSError, EOFError, ValueError, TypeError):
            pass  # missing or damaged: compile again
        code = compile(self.get_data(source), source, "exec", dont_inherit=True, optimize=2)
        if not sys.dont_write_bytecode:
            tmp = f"{cache}.{os.getpid()}.tmp"
            try:
                os.makedirs(os.path.dirname(cache), exist_ok=True)
                with open(tmp, "wb") as fh:
                    fh.write(header + marshal.dumps(code))
                os.replace(tmp, cache)  # whole or not at all, for a concurrent reader
            except OSError:
                try:
                    os.unlink(tmp)
                except OSError:
                    pass
        return code
