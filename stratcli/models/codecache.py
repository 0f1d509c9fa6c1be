"""A disk cache of the numpy source generated for each stratum (start-up speed).

Differentiating a stratum's vector fields and writing numpy code for them (sympy `diff` and
`lambdify` with common subexpressions) takes about 0.1 s per stratum, on every run. What
`lambdify` writes is plain Python source in numpy names; it is kept, with the structure found
beside it (explicit and quadrature coordinates), as one JSON file per stratum under the user's
cache directory: `$XDG_CACHE_HOME/stratplan`, else `~/.cache/stratplan`. The next run executes
that same source in the same namespace `lambdify` uses, so the functions, and every number
they give, are identical.

The key is a SHA-256 of the stratplan version, the sympy version (its printer writes the code),
the source of the generator (`system.py` and this module: a development checkout that changes
them without a version bump never reads stale code), the model's name and coordinates, the
stratum and the exact symbolic fields on it (`srepr`), or instead of the fields the system's
`identity` (presets: their name and the hash of `presets.py`), which spares a warm run from
building the fields at all. So any model is cached, presets and scenario-defined ones alike,
and an edited model is a new key. An entry is written only after
its source, executed again, gave the same numbers as the compiled function at random points.
An unwritable directory, a damaged or foreign entry: the fields are compiled as before, in
silence (the cache is an optimisation, never a failure).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

FORMAT = "stratplan.codecache/1"
GENERATED = "_lambdifygenerated"  # the name lambdify gives the function it writes


def directory() -> Path:
    """The cache directory: `$XDG_CACHE_HOME/stratplan`, else `~/.cache/stratplan`."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "stratplan"


@cache
def sources_hash(*paths: str | Path) -> str:
    """sha256 of the files' bytes, in order: the code that derives what a key caches (a
    change to it makes new keys)."""
    digest = hashlib.sha256()
    for path in paths:
        digest.update(Path(path).read_bytes())
    return digest.hexdigest()


def _generator() -> str:
    """Hash of the code that generates the functions (this module and `system.py`)."""
    here = Path(__file__).resolve().parent
    return sources_hash(here / "system.py", here / "codecache.py")


def key(model: str, states: tuple[str, ...], stratum: str, fields: Any) -> str:
    """The cache key of a stratum's functions (see the module docstring).

    `fields` is the symbolic matrix, or a string that determines it exactly (a system's
    `identity`): then no sympy is imported, and its version is not part of the key (the
    entry is numpy source, checked against the compiled function when it was stored).
    """
    from .. import __version__

    if isinstance(fields, str):
        tool, what = "identity", fields
    else:
        import sympy as sp  # loaded already: the fields are sympy

        tool, what = sp.__version__, sp.srepr(fields)
    parts = (FORMAT, __version__, tool, _generator(), model, ",".join(states), stratum, what)
    digest = hashlib.sha256()
    for part in parts:
        digest.update(part.encode("utf-8") + b"\0")
    return digest.hexdigest()


def _path(k: str) -> Path:
    return directory() / f"{k}.json"


def load(k: str) -> dict[str, Any] | None:
    """The entry stored under `k`, or None (missing, unreadable or not ours)."""
    try:
        entry = json.loads(_path(k).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return entry if isinstance(entry, dict) and entry.get("format") == FORMAT else None


def store(k: str, entry: dict[str, Any]) -> None:
    """Write `entry` under `k` atomically; any OS error leaves the cache as it was."""
    tmp = None
    try:
        folder = directory()
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".", suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump({**entry, "format": FORMAT}, f)
        os.replace(tmp, _path(k))
        tmp = None
    except OSError:
        pass
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


@cache
def _namespace() -> dict[str, Any]:
    """The globals `lambdify(..., modules="numpy")` gives the code it writes."""
    import builtins

    import numpy
    import numpy.linalg

    # `from numpy import *` would also import every lazily loaded submodule numpy lists in
    # `__all__` (f2py, testing, ma, polynomial, …): 0.1 s of a run's start-up, and no
    # generated expression uses them. The names already loaded are the ones lambdify emits.
    namespace: dict[str, Any] = {
        name: vars(numpy)[name] for name in numpy.__all__ if name in vars(numpy)
    }
    namespace.update({name: getattr(numpy.linalg, name) for name in numpy.linalg.__all__})
    namespace["numpy"] = numpy
    namespace.update(
        {"I": 1j, "Heaviside": np.heaviside, "Abs": abs, "builtins": builtins, "range": range}
    )
    return namespace


def function(source: str) -> Callable:
    """The function `source` (as lambdify wrote it) defines, in lambdify's namespace."""
    namespace = dict(_namespace())
    exec(compile(source, "<stratplan codecache>", "exec"), namespace)
    return namespace[GENERATED]


def source_of(func: Callable, n_args: int) -> str | None:
    """The source of a lambdified `func`, or None when executing it again does not give the
    very same numbers at a few random points (then it is not cached)."""
    import inspect

    try:
        source = inspect.getsource(func)
        again = function(source)
    except (OSError, TypeError, SyntaxError, KeyError, NameError):
        return None
    args = np.random.default_rng(0).uniform(-3.0, 3.0, (n_args, 5))
    with np.errstate(all="ignore"):
        a, b = func(*args), again(*args)
    same = len(a) == len(b) and all(
        np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True)
        for x, y in zip(a, b, strict=True)
    )
    return source if same else None
