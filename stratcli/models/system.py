"""Driftless control-affine systems `q' = G(q) u` and their strata (paper eq. 1, 14).

A `System` holds the vector fields symbolically (sympy). For each stratum (`CompiledStratum`,
`compiled_stratum.py`) it finds the structure the quadrature evaluator exploits: *explicit*
coordinates, whose rows of `G` are constant so that `q_E(t) = q_E(0) + C_E ∫u`, and *quadrature*
coordinates, whose rows depend on explicit coordinates only, so that their end value is a plain
integral. Vectorised numpy functions are generated once: the quadrature rows with their first
and second derivatives (fused, `FusedRows`), and `G(q)`, `∂G/∂q` for the ODE path. Their source
is kept in a disk cache (`codecache`), so a model is differentiated and compiled once, not on
every run. A system with an `identity` (the presets) is found in that cache without building its
symbolic fields, so a warm run never imports sympy.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

from ..errors import ModelError, Problem
from ..frozen_json import FrozenDict
from .compiled_stratum import CompiledStratum
from .planar import PlanarManipulator

if TYPE_CHECKING:
    import sympy as sp


@dataclass(frozen=True)
class Stratum:
    """A named subsystem: locked coordinates (zero velocity) and the inputs active on it.

    Attributes
    ----------
    name : str
        "S1", "S13", a custom model's own name, ...
    locked : tuple of int
        The coordinates it locks (0-based).
    active : tuple of int
        The inputs it drives (0-based).
    parameters : tuple of (str, float)
        Model parameters overridden on this stratum (e.g. the biped's contact flags).
    """

    name: str
    locked: tuple[int, ...]
    active: tuple[int, ...]
    parameters: tuple[tuple[str, float], ...] = ()

    def free(self, n: int) -> tuple[int, ...]:
        """Indices of the unlocked coordinates (the stratum's state, paper eq. 7-9).

        Parameters
        ----------
        n : int
            The model's number of coordinates (`System.n`).

        Returns
        -------
        tuple of int
            0-based, in order.
        """
        return tuple(i for i in range(n) if i not in self.locked)


# `System` fields that cannot be rebound once set (`fields` is the subclasses' lazy property)
_SET_ONCE = frozenset(
    {"name", "states", "inputs", "strata", "parameters", "description", "robot", "identity"}
)
_MAPPINGS = ("strata", "parameters")  # held read-only (`FrozenDict`: `dataclasses.asdict`
# deep-copies them, which a `types.MappingProxyType` refused)


@dataclass
class System:
    """A driftless control-affine system with named coordinates, inputs and strata.

    A model is set once (a preset is one object shared by every task of it): its
    attributes cannot be rebound, nor its strata, parameters or fields changed in place.

    Attributes
    ----------
    name : str
        The model's name ("one-arm", "urdf", a scenario's custom name, ...).
    states, inputs : tuple of str
        Coordinate and input names, in order (n and m of them).
    fields : sympy.ImmutableMatrix
        G(q), n x m, in the state and parameter symbols (`q' = G(q) u`, paper eq. 1); a URDF
        model has none (numeric only: `hasattr(system, "fields")` is False).
    strata : Mapping of str to Stratum
        Read-only, by name.
    parameters : Mapping of str to float
        Values of the parameter symbols in `fields` (read-only).
    description : str
        One line for listings.
    robot : PlanarManipulator or None
        The physical robot, for a planar manipulator (presets included).
    spec : model table or None
        The scenario's [model] table it was built from.
    identity : str or None
        What determines `fields` exactly (a preset and its source's hash): keys the code
        cache without building the symbolic fields.
    """

    name: str
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    fields: sp.Matrix  # n x m, in the state symbols and parameter symbols
    strata: Mapping[str, Stratum]
    parameters: Mapping[str, float] = field(default_factory=dict)
    description: str = ""
    robot: PlanarManipulator | None = None  # physical robot, when the model is a manipulator
    spec: Any = None  # the scenario's [model] table it was built from (a plan's reference)
    # Determines `fields` exactly (e.g. a preset and the hash of its source): the code cache
    # is keyed by it, so a warm run needs no symbolic fields at all. None: keyed by the fields.
    identity: str | None = None

    def __post_init__(self) -> None:
        # its compiled functions: a cache, no field (`dataclasses.asdict` recursed through
        # each one's `system` back into this model for good)
        self._compiled: dict[str, CompiledStratum] = {}
        object.__setattr__(self, "_built", True)  # from now on `fields` is read-only too

    def __repr__(self) -> str:  # the dataclass's prints the symbolic fields (kB, padded)
        return (
            f"{type(self).__name__}({self.name!r}: coordinates {', '.join(self.states)}; "
            f"inputs {', '.join(self.inputs)}; strata {', '.join(self.strata)})"
        )

    def __setattr__(self, name: str, value: Any) -> None:
        """A model's fields are set once, and its strata, parameters and symbolic fields
        cannot be changed in place: `preset(name)` is one object shared by every task of
        that model, so `task.system.name = ...` renamed it in every plan, and
        `system.strata["S1"] = None` broke every later load of the model in the process."""
        if (name in _SET_ONCE and name in self.__dict__) or (
            name == "fields" and self.__dict__.get("_built")
        ):
            raise AttributeError(
                f"{type(self).__name__}.{name} is read-only (a model may be shared by many "
                f"tasks, every preset is): build another model instead"
            )
        if name in _MAPPINGS:
            value = FrozenDict(value)
        elif name in ("fields", "_fields") and hasattr(value, "as_immutable"):
            value = value.as_immutable()  # a sympy Matrix, which `fields[i, j] = ...` changed
        object.__setattr__(self, name, value)

    def __getstate__(self) -> dict:
        """Pickled without its compiled functions (lambdified code does not pickle); they
        are generated again on first use where the system is unpickled."""
        state = dict(self.__dict__)
        state["_compiled"] = {}
        state.pop("_row_cache", None)  # `controllability._rows`: only a speed-up
        state.pop("_lie_cache", None)  # Lie brackets (`liealgebra`): generated code, likewise
        return state  # (its `FrozenDict`s pickle as plain dicts: `__setstate__` freezes them)

    def __setstate__(self, state: dict) -> None:
        for name in _MAPPINGS:
            if name in state:
                state[name] = FrozenDict(state[name])
        self.__dict__.update(state)

    @cached_property
    def symbols(self) -> tuple[sp.Symbol, ...]:
        import sympy as sp

        return tuple(sp.Symbol(s, real=True) for s in self.states)

    @property
    def n(self) -> int:
        """Number of coordinates (the configuration's length)."""
        return len(self.states)

    @property
    def m(self) -> int:
        """Number of inputs (controls)."""
        return len(self.inputs)

    def stratum(self, name: str) -> Stratum:
        """The stratum called `name`.

        Parameters
        ----------
        name : str
            As in `strata` (e.g. "S1").

        Returns
        -------
        Stratum

        Raises
        ------
        ModelError
            The model has no such stratum (the message lists those it has).
        """
        try:
            return self.strata[name]
        except KeyError:
            known = ", ".join(self.strata)
            raise ModelError(f"unknown stratum {name!r} (this model has: {known})") from None

    def fields_on(self, stratum: Stratum) -> sp.Matrix:
        """Vector fields of the stratum's active inputs, parameters substituted (sympy).

        Parameters
        ----------
        stratum : Stratum
            One of the model's strata (its `parameters` override the model's).

        Returns
        -------
        sympy.Matrix
            Shape (n, len(stratum.active)): a column per active input.
        """
        import sympy as sp

        values = dict(self.parameters)
        values.update(dict(stratum.parameters))
        subs = {sp.Symbol(k, real=True): sp.Rational(repr(float(v))) for k, v in values.items()}
        # (a mutable copy: its srepr keys the code cache, as before `fields` was immutable)
        G = sp.Matrix(self.fields.extract(list(range(self.n)), list(stratum.active)))
        return G.subs(subs) if subs else G

    def compiled(self, stratum: Stratum | str) -> CompiledStratum:
        """Numeric functions of a stratum, generated on first use and cached.

        Parameters
        ----------
        stratum : Stratum or str
            The stratum, or its name.

        Returns
        -------
        CompiledStratum
            What the end-point evaluators use (its inputs are the stratum's active ones).

        Raises
        ------
        ModelError
            Unknown stratum, or fields sympy cannot differentiate or compile.
        """
        s = self.stratum(stratum) if isinstance(stratum, str) else stratum
        if s.name not in self._compiled:
            try:
                self._compiled[s.name] = CompiledStratum(self, s)
            except ModelError:
                raise
            except _SYMBOLIC_FAILURES as exc:
                raise ModelError(
                    [Problem(f"model.strata.{s.name}", _cannot_compile(exc))]
                ) from None
        return self._compiled[s.name]

    def check(self) -> None:
        """Validate strata against the fields: a locked coordinate must not move.

        Raises
        ------
        ModelError
            A locked coordinate moves, a stratum has no inputs, or sympy cannot handle the
            fields on a stratum (reported as a problem of that stratum, not a traceback).
        """
        problems = []
        for s in self.strata.values():
            try:
                G = self.fields_on(s)
                nonzero = [
                    [G[i, j].is_zero is not True for j in range(G.shape[1])] for i in s.locked
                ]
            except _SYMBOLIC_FAILURES as exc:
                problems.append(Problem(f"strata.{s.name}", _cannot_compile(exc)))
                continue
            for i, row in zip(s.locked, nonzero, strict=True):
                moving = [self.inputs[s.active[j]] for j, moves in enumerate(row) if moves]
                if moving:
                    problems.append(
                        Problem(
                            f"strata.{s.name}",
                            f"coordinate {self.states[i]!r} is locked but moved by active "
                            f"input(s) {', '.join(moving)}",
                        )
                    )
            if not s.active:
                problems.append(Problem(f"strata.{s.name}", "no active inputs"))
        if problems:
            raise ModelError(problems)


_SYMBOLIC_FAILURES = (
    ArithmeticError,
    TypeError,
    ValueError,
    AttributeError,
    RecursionError,
    MemoryError,
    SyntaxError,
)


def _cannot_compile(exc: BaseException) -> str:
    detail = str(exc).splitlines()[0][:120] if str(exc) else ""
    kind = f"{type(exc).__name__}: {detail}" if detail else type(exc).__name__
    return f"the vector fields cannot be compiled ({kind})"


def make_strata(
    states: tuple[str, ...],
    inputs: tuple[str, ...],
    spec: Mapping[str, tuple[tuple[str, ...], tuple[str, ...]]],
) -> dict[str, Stratum]:
    """Build strata from {name: (locked state names, active input names)}."""
    return {
        name: Stratum(
            name,
            tuple(states.index(s) for s in locked),
            tuple(inputs.index(u) for u in active),
        )
        for name, (locked, active) in spec.items()
    }
