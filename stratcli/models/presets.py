"""The paper's two space-manipulator models, exactly as printed (eq. 5-13).

`θ' = Σ A_i(q) u_i` with `A_i = f_i / f_θ`; joint `i` is driven by `u_i`. Stratum `Si` locks
joint `i` (its input is off), `Sij` locks joints `i` and `j` (two-arm model only).

`PRESET_TABLE` describes the presets without building them: `stratplan models` lists it
without importing sympy (a test checks it equals the built systems). A preset `System` is
made from that table too; its symbolic fields are built on first use only, and its `identity`
(name and the hash of this file) keys the code cache, so a run whose strata are cached never
imports sympy.
"""

from __future__ import annotations

import hashlib
from functools import cache
from itertools import combinations
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from .system import System, make_strata

if TYPE_CHECKING:
    import sympy as sp


class PresetInfo(NamedTuple):
    """What `stratplan models` lists of a preset, known without building it."""

    states: tuple[str, ...]
    inputs: tuple[str, ...]
    strata: tuple[str, ...]
    description: str


_TWO_ARM_STRATA = tuple(
    "S" + "".join(str(i + 1) for i in locked)
    for size in (1, 2)
    for locked in combinations(range(4), size)
)
PRESET_TABLE = {
    "one-arm": PresetInfo(
        ("q1", "q2", "q3", "theta"),
        ("u1", "u2", "u3"),
        ("S1", "S2", "S3"),
        "one-arm space manipulator, 3 joints (Duleba & Opalka eq. 5-9)",
    ),
    "two-arm": PresetInfo(
        ("q1", "q2", "q3", "q4", "theta"),
        ("u1", "u2", "u3", "u4"),
        _TWO_ARM_STRATA,
        "two-arm space manipulator, 2 x 2 joints (Duleba & Opalka eq. 10-13)",
    ),
}


def _c(*qs: sp.Symbol) -> sp.Expr:
    import sympy as sp  # start-up speed (module docstring)

    return sp.cos(sum(qs))


def _fields(k: int, f: list[sp.Expr], f_theta: sp.Expr) -> sp.Matrix:
    """`G` of a k-joint preset: joint i driven by u_i, `θ' = Σ f_i / f_θ u_i`."""
    import sympy as sp  # start-up speed (module docstring)

    G = sp.zeros(k + 1, k)
    for i in range(k):
        G[i, i] = 1
        G[k, i] = f[i] / f_theta
    return G


def _one_arm_fields() -> sp.Matrix:
    """One-arm, three-joint free-floating manipulator, paper eq. 5-9."""
    import sympy as sp  # start-up speed (module docstring)

    q1, q2, q3 = sp.symbols("q1 q2 q3", real=True)
    f1 = -(
        90 * _c(q1)
        + 378 * _c(q2)
        + 138 * _c(q3)
        + 54 * _c(q1, q2)
        + 126 * _c(q2, q3)
        + 18 * _c(q1, q2, q3)
        + 636
    )
    f2 = -(
        189 * _c(q2) + 138 * _c(q3) + 54 * _c(q1, q2) + 63 * _c(q2, q3) + 18 * _c(q1, q2, q3) + 308
    )
    f3 = -(69 * _c(q3) + 63 * _c(q2, q3) + 18 * _c(q1, q2, q3) + 88)
    f_theta = (
        180 * _c(q1)
        + 378 * _c(q2)
        + 138 * _c(q3)
        + 108 * _c(q1, q2)
        + 126 * _c(q2, q3)
        + 36 * _c(q1, q2, q3)
        + sp.Rational(4226, 5)
    )

    return _fields(3, [f1, f2, f3], f_theta)


def _two_arm_fields() -> sp.Matrix:
    """Two-arm, four-joint free-floating manipulator, paper eq. 10-13."""
    import sympy as sp  # start-up speed (module docstring)

    q1, q2, q3, q4 = sp.symbols("q1 q2 q3 q4", real=True)
    c = _c
    f1 = -(
        171 * c(q1)
        + 210 * c(q2)
        + 57 * c(q1, q2)
        + 27 * c(q1, q3)
        + 9 * c(q1, q2, q3)
        + 9 * c(q1, q3, q4)
        + 3 * c(q1, q2, q3, q4)
        + 464
    )
    f2 = -(105 * c(q2) + 57 * c(q1, q2) + 9 * c(q1, q2, q3) + 3 * c(q1, q2, q3, q4) + 130)
    f3 = (
        171 * c(q3)
        + 27 * c(q1, q3)
        + 9 * c(q1, q2, q3)
        + 210 * c(q4)
        + 57 * c(q3, q4)
        + 9 * c(q1, q3, q4)
        + 3 * c(q1, q2, q3, q4)
        + 464
    )
    f4 = 105 * c(q4) + 57 * c(q3, q4) + 9 * c(q1, q3, q4) + 3 * c(q1, q2, q3, q4) + 130
    f_theta = (
        342 * c(q1)
        + 210 * c(q2)
        + 342 * c(q3)
        + 210 * c(q4)
        + 114 * c(q1, q2)
        + 54 * c(q1, q3)
        + 114 * c(q3, q4)
        + 18 * c(q1, q2, q3)
        + 18 * c(q1, q3, q4)
        + 6 * c(q1, q2, q3, q4)
        + 1726
    )

    return _fields(4, [f1, f2, f3, f4], f_theta)


_BUILDERS = {"one-arm": _one_arm_fields, "two-arm": _two_arm_fields}


@cache
def _source_hash() -> str:
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


class PresetSystem(System):
    """A preset: coordinates, strata and robot from `PRESET_TABLE`, fields built lazily."""

    def __init__(self, name: str):
        from .planar import paper_one_arm, paper_two_arm

        info = PRESET_TABLE[name]
        states, inputs = info.states, info.inputs
        spec = {}
        for stratum in info.strata:  # "S13": joints 1 and 3 locked, their inputs off
            locked = [int(c) - 1 for c in stratum[1:]]
            spec[stratum] = (
                tuple(states[i] for i in locked),
                tuple(u for j, u in enumerate(inputs) if j not in locked),
            )
        robot = {"one-arm": paper_one_arm, "two-arm": paper_two_arm}[name]()
        super().__init__(
            name,
            states,
            inputs,
            None,
            make_strata(states, inputs, spec),
            description=info.description,
            robot=robot,
            identity=f"preset {name}; presets.py sha256 {_source_hash()}",
        )

    @property
    def fields(self) -> sp.Matrix:  # the printed equations, built on first use only
        if self._fields is None:
            self._fields = _BUILDERS[self.name]()
        return self._fields

    @fields.setter
    def fields(self, value) -> None:
        self._fields = value


def one_arm() -> System:
    """One-arm, three-joint free-floating manipulator, paper eq. 5-9."""
    return PresetSystem("one-arm")


def two_arm() -> System:
    """Two-arm, four-joint free-floating manipulator, paper eq. 10-13."""
    return PresetSystem("two-arm")


PRESETS = {"one-arm": one_arm, "two-arm": two_arm}


def preset(name: str) -> System:
    """A preset model by name; one shared instance, so its numeric functions compile once.

    Parameters
    ----------
    name : str
        "one-arm" (paper eq. 5-9) or "two-arm" (eq. 10-13).

    Returns
    -------
    System
        The model (the same object for every call with this name).

    Raises
    ------
    InputError
        `name` is no preset (the message names the presets and the nearest).
    TypeError
        `name` is no str.
    """
    if not isinstance(name, str):
        from ..arguments import wrong_type

        raise wrong_type("name", "a preset's name (a str)", name)
    if name not in PRESETS:
        from ..errors import InputError

        raise InputError(f"name: no preset {name!r} ({meant_preset(name)})")
    return _shared(name)


def meant_preset(name: str) -> str:
    """The presets, the one nearest a misspelt `name` first: "did you mean 'one-arm'?
    presets: one-arm, two-arm" (`preset`, `stratplan models one_arm`)."""
    from difflib import get_close_matches

    near = get_close_matches(name, PRESETS, n=1, cutoff=0.6)
    meant = f"did you mean {near[0]!r}? " if near else ""
    return f"{meant}presets: {', '.join(PRESETS)}"


@cache
def _shared(name: str) -> System:
    return PRESETS[name]()
