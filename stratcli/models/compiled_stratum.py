"""The numeric functions of one stratum (`CompiledStratum`): which coordinates are explicit
(constant rows of G: `q_E(t) = q_E(0) + C_E ∫u`) and which are plain integrals of them
(quadrature rows), with the generated functions the end-point evaluators call, kept in the
disk cache (`codecache`). `System.compiled` makes them (paper eq. 1, 14).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from . import codecache
from .generated import ArrayFunction, FusedRows

if TYPE_CHECKING:
    import sympy as sp

    from .system import Stratum, System

__all__ = ["CompiledStratum"]


@dataclass
class CompiledStratum:
    """Numeric functions of one stratum; inputs are the stratum's active inputs only.

    The quadrature path needs only `quadrature_terms`; the full `G` and `∂G/∂q` (the ODE
    path) are generated on first use.
    """

    system: System
    stratum: Stratum
    explicit: tuple[int, ...] = field(init=False)
    quadrature: tuple[int, ...] = field(init=False)
    C_explicit: np.ndarray = field(init=False)  # |E| x m_active constant rows
    # rows of `explicit` that `quadrature_terms` differentiates along: those an active input
    # moves (a locked joint stays where it is, so derivatives along it are never needed)
    derivatives_along: tuple[int, ...] = field(init=False)
    quadrature_terms: FusedRows | None = field(init=False)  # None: no quadrature path
    _key: str = field(init=False, repr=False)  # of the disk cache (codecache)
    _entry: dict = field(init=False, repr=False)  # what the cache holds of this stratum

    def __post_init__(self) -> None:
        system = self.system
        what = system.identity if system.identity is not None else self.G_sym
        self._key = codecache.key(system.name, system.states, self.stratum.name, what)
        self._entry = codecache.load(self._key) or {}
        if self._entry:
            try:
                self._restore(self._entry)
                return
            except Exception:  # a damaged entry: generate the functions again
                self._entry = {}
        self._generate()
        rows = self.quadrature_terms.sources() if self.quadrature_terms else None
        self._entry.update(
            explicit=self.explicit,
            quadrature=self.quadrature,
            C_explicit=self.C_explicit.tolist(),
            along=self.derivatives_along,
            rows=rows,
            sizes=self.quadrature_terms._sizes if self.quadrature_terms else None,
        )
        for name in ("G", "dG"):  # generated already when the ODE path is the only one
            if name in self.__dict__:
                self._entry[name] = self.__dict__[name].saved()
        if rows is not None or self.quadrature_terms is None:
            codecache.store(self._key, self._entry)

    def _restore(self, entry: dict) -> None:
        self.explicit = tuple(entry["explicit"])
        self.quadrature = tuple(entry["quadrature"])
        m = len(self.stratum.active)
        self.C_explicit = np.array(entry["C_explicit"], dtype=float).reshape(len(self.explicit), m)
        self.derivatives_along = tuple(entry["along"])
        self.quadrature_terms = None
        if entry["sizes"] is not None:
            self.quadrature_terms = FusedRows.restored(entry["sizes"], entry["rows"])
        else:
            _ = self.G, self.dG  # the ODE path is the only one: compile now

    def _generate(self) -> None:
        q = list(self.system.symbols)
        G = self.G_sym
        n, m = G.shape
        state_syms = set(q)
        depends = [G.row(i).free_symbols & state_syms for i in range(n)]
        explicit = tuple(i for i in range(n) if not depends[i])
        explicit_syms = {q[i] for i in explicit}
        quad = tuple(i for i in range(n) if depends[i])
        self.explicit = explicit
        self.quadrature = quad
        self.C_explicit = np.array(
            [[float(G[i, j]) for j in range(m)] for i in explicit], dtype=float
        ).reshape(len(explicit), m)
        self.derivatives_along = tuple(
            r for r in range(len(explicit)) if np.any(self.C_explicit[r] != 0.0)
        )
        self.quadrature_terms = None
        if all(depends[i] <= explicit_syms for i in quad):
            rows = G.extract(list(quad), list(range(m)))
            along = tuple(explicit[r] for r in self.derivatives_along)
            self.quadrature_terms = FusedRows(rows, q, along)
            self.quadrature_terms.compile(2)
        else:
            _ = self.G, self.dG  # the ODE path is the only one: compile now

    @cached_property
    def G_sym(self) -> sp.Matrix:  # n x m_active, parameters substituted; built on a cache miss
        return self.system.fields_on(self.stratum)

    @cached_property
    def G(self) -> ArrayFunction:  # (..., n) -> (..., n, m_active)
        return self._array("G", lambda: self.G_sym)

    @cached_property
    def dG(self) -> ArrayFunction:  # (..., n) -> (..., n, m_active, n)
        return self._array("dG", self._dG_sym)

    def _dG_sym(self) -> sp.NDimArray:
        import sympy as sp

        q, (n, m) = list(self.system.symbols), self.G_sym.shape
        flat = [
            sp.diff(self.G_sym[i, j], q[k]) for i in range(n) for j in range(m) for k in range(n)
        ]
        return sp.MutableDenseNDimArray(flat, (n, m, n))

    def _array(self, name: str, build: Callable[[], Any]) -> ArrayFunction:
        """`G` or `dG` from the disk cache, else generated (and then cached)."""
        if self._entry.get(name):
            try:
                return ArrayFunction.restored(self._entry[name], self.system.n)
            except Exception:  # a damaged entry: generate it again
                pass
        func = ArrayFunction(build(), list(self.system.symbols))
        saved = func.saved() if "explicit" in self._entry else None  # else: __post_init__
        if saved is not None:
            self._entry[name] = saved
            codecache.store(self._key, self._entry)
        return func

    @property
    def supports_quadrature(self) -> bool:
        """True when every non-constant row depends only on constant-row coordinates."""
        return self.quadrature_terms is not None
