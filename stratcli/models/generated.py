"""Generated numpy functions of a model's symbolic rows (their source kept by `codecache`).

`ArrayFunction` evaluates a sympy array at many points, filling only its nonzero entries;
`FusedRows` evaluates a stratum's quadrature rows with their first and second derivatives
in one generated function. Both can be rebuilt from the disk cache without sympy.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from . import codecache

if TYPE_CHECKING:
    import sympy as sp

__all__ = ["ArrayFunction", "FusedRows", "cached_function", "keep_function"]


class ArrayFunction:
    """Evaluate a sympy array of shape `shape` at many points, filling only nonzero entries.

    Made from `saved` (what `saved()` returned, kept in the disk cache) no sympy is needed.
    """

    def __init__(self, array: Any, symbols: list[sp.Symbol], saved: dict | None = None):
        if saved is None:
            import sympy as sp  # only to generate: a cached function needs none

            self.shape = tuple(array.shape)
            flat = [array[idx] for idx in np.ndindex(*self.shape)]
            self.index = [i for i, e in enumerate(flat) if sp.sympify(e).is_zero is not True]
            exprs = _no_deltas([flat[i] for i in self.index])
            self._func = sp.lambdify(symbols, exprs, modules="numpy", cse=True) if exprs else None
        else:
            self.shape, self.index = tuple(saved["shape"]), list(saved["index"])
            self._func = codecache.function(saved["source"]) if self.index else None
        self._n = len(symbols)
        self._flat = np.array(self.index, dtype=int)

    @classmethod
    def restored(cls, saved: dict, n: int) -> ArrayFunction:
        """Again from what `saved()` returned, for `n` coordinates (no sympy)."""
        return cls(None, [None] * n, saved=saved)

    def saved(self) -> dict | None:
        """What the disk cache keeps of it, or None when its source cannot be kept."""
        source = codecache.source_of(self._func, self._n) if self._func else None
        if self._func and source is None:
            return None
        return {"shape": list(self.shape), "index": self.index, "source": source}

    def __call__(self, q: np.ndarray) -> np.ndarray:
        lead = q.shape[:-1]
        out = np.zeros((*lead, int(np.prod(self.shape))))
        values = self._func(*np.moveaxis(q, -1, 0)) if self._func else []
        for i, value in zip(self.index, values, strict=True):
            out[..., i] = value
        return out.reshape(*lead, *self.shape)

    def at(self, q: np.ndarray) -> np.ndarray:
        """`self(q)` at one point q (n,), with a fraction of the overhead: an ODE right-hand
        side calls it thousands of times, where the wrapper above costs more than the
        expressions. Python floats in (cheaper arithmetic than numpy scalars); where they
        raise or turn complex (1/0.0, a negative base to a fractional power), numpy scalars
        again, so the numbers are those of `self(q)`."""
        out = np.zeros(self.shape)
        if self._func is not None:
            flat = out.reshape(-1)  # a view
            try:
                flat[self._flat] = self._func(*q.tolist())
            except (ArithmeticError, TypeError):
                flat[self._flat] = self._func(*q)
        return out


def _no_deltas(exprs: list) -> list:
    """`exprs` with every Dirac delta 0: the derivative of `abs(x)` is `sign(x)`, whose own is
    a delta at 0, which numpy has no name for (it raised NameError: 'DiracDelta' in the middle
    of a plan); 0 everywhere but at the kink, where no numerical derivative is better."""
    import sympy as sp

    return [
        e.replace(sp.DiracDelta, lambda *args: sp.S.Zero) if isinstance(e, sp.Basic) else e
        for e in exprs
    ]


def _derivatives(exprs: list[sp.Expr], symbols: list[sp.Symbol]) -> list[sp.Expr]:
    """`∂e/∂s` for every e of `exprs` (outer) and s of `symbols` (inner), flat."""
    import sympy as sp

    return [sp.diff(e, s) for e in exprs for s in symbols]


def cached_function(key: str | None, n: int) -> tuple[ArrayFunction, dict] | None:
    """The `ArrayFunction` of `n` coordinates kept under `key` in the disk cache (no sympy),
    with its whole entry (what `keep_function` stored beside it); None when there is none or
    it is damaged (then it is derived again)."""
    entry = codecache.load(key) if key else None
    if not entry:
        return None
    try:
        return ArrayFunction.restored(entry["rows"], n), entry
    except Exception:  # a damaged entry
        return None


def keep_function(key: str | None, function: ArrayFunction, **beside: Any) -> None:
    """Keep `function` (and `beside`) under `key` in the disk cache, where it can be kept."""
    saved = function.saved() if key else None
    if saved is not None:
        codecache.store(key, {**beside, "rows": saved})


class FusedRows:
    """The quadrature rows `G_Q(q)` and their first and second derivatives along the explicit
    coordinates `explicit` (the stratum's moving ones), each order one numpy function with
    common subexpressions shared.

    On the few hundred quadrature nodes of a leg the cost is the number of numpy operations,
    not the array length, so fusing the derivatives with the rows (and stacking rather than
    differencing for the second ones) is what makes the Jacobian and Hessian cheap.
    """

    def __init__(self, rows: sp.Matrix, symbols: list[sp.Symbol], explicit: tuple[int, ...]):
        import sympy as sp

        nQ, m = rows.shape
        nE = len(explicit)
        self._sizes = (nQ, m, nE)
        along = [symbols[k] for k in explicit]
        flat0 = [rows[i, j] for i in range(nQ) for j in range(m)]
        flat1 = _derivatives(flat0, along)
        # second derivatives: only the upper triangle (e ≤ f) is compiled, then mirrored
        pairs = [(e, f) for e in range(nE) for f in range(e, nE)]
        flat2 = [sp.diff(flat1[r * nE + e], along[f]) for r in range(len(flat0)) for e, f in pairs]
        self._pairs = pairs
        self._symbols = symbols
        self._flats = (flat0, flat0 + flat1, flat0 + flat1 + flat2)
        self._funcs: list[Callable | None] = [None, None, None]

    @classmethod
    def restored(cls, sizes: tuple[int, int, int], sources: list[str]) -> FusedRows:
        """The three functions again from their cached source, nothing differentiated."""
        self = cls.__new__(cls)
        self._sizes = tuple(sizes)
        nE = self._sizes[2]
        self._pairs = [(e, f) for e in range(nE) for f in range(e, nE)]
        self._funcs = [codecache.function(source) for source in sources]
        return self

    def sources(self) -> list[str] | None:
        """The source of the three compiled functions, or None if one cannot be kept."""
        self.compile(2)
        found = [codecache.source_of(f, len(self._symbols)) for f in self._funcs]
        return None if None in found else found

    def _func(self, order: int) -> Callable:
        if self._funcs[order] is None:
            import sympy as sp

            self._funcs[order] = sp.lambdify(
                self._symbols, _no_deltas(self._flats[order]), modules="numpy", cse=True
            )
        return self._funcs[order]

    def compile(self, order: int = 2) -> None:
        """Generate the functions up to `order` now (e.g. before forking workers)."""
        for k in range(order + 1):
            self._func(k)

    def __call__(self, q: np.ndarray, order: int) -> tuple[np.ndarray, ...]:
        """(rows (..., nQ, m), [d (..., nQ, m, nE), [dd (..., nQ, m, nE, nE)]]) at points q."""
        lead = q.shape[:-1]
        values = self._func(order)(*(q.T if q.ndim == 2 else np.moveaxis(q, -1, 0)))
        flat = np.empty((*lead, len(values)))
        for i, v in enumerate(values):
            flat[..., i] = v
        nQ, m, nE = self._sizes
        a, b = nQ * m, nQ * m * (1 + nE)
        out = [flat[..., :a].reshape(*lead, nQ, m)]
        if order >= 1:
            out.append(flat[..., a:b].reshape(*lead, nQ, m, nE))
        if order == 2:  # mirror the compiled upper triangle
            upper = flat[..., b:].reshape(*lead, nQ * m, len(self._pairs))
            dd = np.empty((*lead, nQ * m, nE, nE))
            e, f = np.array(self._pairs).T
            dd[..., e, f] = upper
            dd[..., f, e] = upper
            out.append(dd.reshape(*lead, nQ, m, nE, nE))
        return tuple(out)
