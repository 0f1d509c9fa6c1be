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
(`PYTHONDONTWRITEBYTECODE`, `-B`) or a package directory where no file can be created, a
module whose optimised bytecode is not there and current is imported the usual way. The
library never calls this; `stratcli.__main__` does, before anything imports matplotlib.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import marshal
import os
import sys
import types

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
        if type(loader) is importlib.machinery.SourceFileLoader:  # not an extension, a zip
            spec.loader = _Loader(loader.name, loader.path)
        return spec

    def invalidate_caches(self) -> None:  # importlib.invalidate_caches() calls every finder
        pass


class _Loader(importlib.machinery.SourceFileLoader):
    """Loads a module's optimisation-level-2 bytecode, writing it when it is missing or
    stale; where it cannot be written, the module loads the usual way (so a read-only install
    never compiles matplotlib from source on every run)."""

    def get_code(self, fullname: str):
        source = self.get_filename(fullname)
        cache, header = _cache(source), _header(source)
        try:
            with open(cache, "rb") as fh:
                data = fh.read()
            if data[:16] == header:
                code = marshal.loads(data[16:])
                if isinstance(code, types.CodeType):
                    return code
        except (OSError, EOFError, ValueError, TypeError):
            pass  # missing or damaged
        if sys.dont_write_bytecode or not _can_write(os.path.dirname(cache)):
            return super().get_code(fullname)
        code = compile(self.get_data(source), source, "exec", dont_inherit=True, optimize=2)
        _write(cache, header + marshal.dumps(code), os.stat(source).st_mode)
        return code


_writable: dict[str, bool] = {}  # folder -> whether a file could be created there


def _can_write(folder: str) -> bool:
    """Whether a file can be created in `folder` (made if missing): tried, not guessed from
    permission bits, which network file systems and Windows ACLs do not honour."""
    if folder not in _writable:
        probe = os.path.join(folder, f".stratplan-probe-{os.getpid()}")
        try:
            os.makedirs(folder, exist_ok=True)
            os.close(os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
            os.unlink(probe)
            _writable[folder] = True
        except OSError:
            _writable[folder] = False
    return _writable[folder]


def _write(cache: str, data: bytes, source_mode: int) -> None:
    """Write `cache` whole or not at all (a concurrent reader sees the old file or the new),
    with the source's permissions as CPython gives its own caches."""
    tmp = f"{cache}.{os.getpid()}.tmp"
    try:
        fd = os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, (source_mode | 0o200) & 0o666)
        with open(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, cache)
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
