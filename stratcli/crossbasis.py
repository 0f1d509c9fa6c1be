"""The closure of several strata's fields *across* the strata (eq. 2 when their sum falls short).

Brackets between fields of different strata, which switching back and forth between the
strata realises (Goodwine's stratified construction; `controllability.sequence_report`):

* a physical manipulator (or a URDF robot): closed form, one stratum with all the strata's
  inputs (`_manipulator_cross_basis`);
* any other model: the Hall basis of the strata's distinct fields, derived with sympy
  (`symbolic_cross_basis`). For a system with an `identity` (the presets) the compiled
  function and its labels are kept in the code cache (`models.codecache`), keyed like the
  strata's brackets (`liealgebra._cache_key`) by the identity, the strata, the degree and the
  source of this module and `liealgebra.py`: a warm run imports no sympy. An unwritable cache
  or a damaged entry: derived as before, in silence.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from .liealgebra import bracket, element_label, hall_basis, lie_basis
from .models import codecache
from .models.generated import ArrayFunction, cached_function, keep_function
from .models.manipulator import ManipulatorSystem
from .models.system import Stratum, System

if TYPE_CHECKING:
    import sympy as sp


@dataclass
class CrossBasis:
    """Labels of the basis fields (`u1@S1`, `[u1@S1,u2@S2]`, …) and their values at
    configurations (..., n) as (..., n, r)."""

    labels: list[str]
    evaluate: ArrayFunction


def cross_basis(system: System, strata: tuple[str, ...], degree: int) -> CrossBasis:
    """Hall basis of all distinct fields of `strata` together (cached on the system and, for
    a system with an `identity`, on disk)."""
    memo = system.__dict__.setdefault("_lie_cache", {})
    key = ("cross", strata, degree)
    if key not in memo:
        if isinstance(system, ManipulatorSystem) or getattr(system, "spatial", None) is not None:
            memo[key] = _manipulator_cross_basis(system, strata, degree)  # spatial: numeric
        else:
            memo[key] = _cached_cross_basis(system, strata, degree)
    return memo[key]


def _manipulator_cross_basis(
    system: ManipulatorSystem, strata: tuple[str, ...], degree: int
) -> CrossBasis:
    """A manipulator's input u_j drives the same field on every stratum where it is active:
    the closure across strata is the closed-form basis of one stratum with all their inputs."""
    first: dict[int, str] = {}
    for name in strata:
        for j in system.stratum(name).active:
            first.setdefault(j, name)
    union = Stratum("+".join(strata), (), tuple(first))  # in the order the strata give them
    basis = lie_basis(system, union, degree)  # closed form (liealgebra._manipulator_basis)
    names = [f"{system.inputs[j]}@{first[j]}" for j in union.active]
    # (n, r) rows as every CrossBasis has them: a URDF stratum's own rows are its free ones
    return CrossBasis([element_label(h, names) for h in basis.elements], basis.full)


def _cached_cross_basis(system: System, strata: tuple[str, ...], degree: int) -> CrossBasis:
    """`symbolic_cross_basis`, read from the code cache when the system has an identity."""
    key = cache_key(system, strata, degree)
    if found := cached_function(key, system.n):  # as derived and compiled before: no sympy
        evaluate, entry = found
        labels = entry.get("labels")
        if isinstance(labels, list) and evaluate.shape[1:] == (len(labels),):
            return CrossBasis([str(label) for label in labels], evaluate)
    basis = symbolic_cross_basis(system, strata, degree)  # (also for a damaged entry)
    keep_function(key, basis.evaluate, labels=basis.labels)
    return basis


def cache_key(system: System, strata: tuple[str, ...], degree: int) -> str | None:
    """The code-cache key of the closure across `strata`, for systems with an `identity`."""
    if system.identity is None:
        return None
    what = f"{system.identity}; crossbasis.py, liealgebra.py sha256 {_source_hash()}"
    return codecache.key(system.name, system.states, f"{'+'.join(strata)} across {degree}", what)


def _source_hash() -> str:
    """Hash of the code that derives the basis (this module and `liealgebra.py`)."""
    here = Path(__file__).resolve().parent
    return codecache.sources_hash(here / "crossbasis.py", here / "liealgebra.py")


def symbolic_cross_basis(system: System, strata: tuple[str, ...], degree: int) -> CrossBasis:
    """The closure across `strata` derived with sympy (each distinct field once)."""
    import sympy as sp  # only here: a cached model never needs sympy

    symbols = list(system.symbols)
    generators: list[sp.Matrix] = []
    names: list[str] = []
    for name in strata:
        s = system.stratum(name)
        G = system.fields_on(s)
        for c, j in enumerate(s.active):
            col = G[:, c]
            if any((col - g).is_zero_matrix for g in generators):
                continue
            generators.append(col)
            names.append(f"{system.inputs[j]}@{s.name}")
    elements = hall_basis(len(generators), degree)
    fields: dict = {}
    every = tuple(range(system.n))
    for h in elements:
        fields[h] = (
            generators[h]
            if isinstance(h, int)
            else bracket(fields[h[0]], fields[h[1]], symbols, every)
        )
    matrix = sp.Matrix.hstack(*(fields[h] for h in elements))
    return CrossBasis([element_label(h, names) for h in elements], ArrayFunction(matrix, symbols))
