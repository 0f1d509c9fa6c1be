"""The paper's two space-manipulator models, exactly as printed (eq. 5-13).

`θ' = Σ A_i(q) u_i` with `A_i = f_i / f_θ`; joint `i` is driven by `u_i`. Stratum `Si` locks
joint `i` (its input is off), `Sij` locks joints `i` and `j` (two-arm model only).

`PRESET_TABLE` describes the presets without building them: `stratplan models` lists it
without importing sympy (a test checks it equals the built systems). sympy is imported by the
functions that build a model, for the same start-up speed.
"""

from __future__ import annotations

from functools import cache
from itertools import combinations
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    import sympy as sp

    from .system import System


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


def _manipulator(name: str, k: int, f: list[sp.Expr], f_theta: sp.Expr, strata) -> System:
    import sympy as sp  # start-up speed (module docstring)

    from .system import System, make_strata

    states = (*(f"q{i}" for i in range(1, k + 1)), "theta")
    inputs = tuple(f"u{i}" for i in range(1, k + 1))
    G = sp.zeros(k + 1, k)
    for i in range(k):
        G[i, i] = 1
        G[k, i] = f[i] / f_theta
    return System(name, states, inputs, G, make_strata(states, inputs, strata(states, inputs)))


def one_arm() -> System:
    """One-arm, three-joint free-floating manipulator, paper eq. 5-9."""
    import sympy as sp  # start-up speed (module docstring)

    from .planar import paper_one_arm

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

    def strata(states, inputs):
        return {
            f"S{i + 1}": ((states[i],), tuple(u for j, u in enumerate(inputs) if j != i))
            for i in range(3)
        }

    system = _manipulator("one-arm", 3, [f1, f2, f3], f_theta, strata)
    system.description = PRESET_TABLE["one-arm"].description
    system.robot = paper_one_arm()
    return system


def two_arm() -> System:
    """Two-arm, four-joint free-floating manipulator, paper eq. 10-13."""
    import sympy as sp  # start-up speed (module docstring)

    from .planar import paper_two_arm

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

    def strata(states, inputs):
        out = {}
        for size in (1, 2):
            for locked in combinations(range(4), size):
                name = "S" + "".join(str(i + 1) for i in locked)
                out[name] = (
                    tuple(states[i] for i in locked),
                    tuple(u for j, u in enumerate(inputs) if j not in locked),
                )
        return out

    system = _manipulator("two-arm", 4, [f1, f2, f3, f4], f_theta, strata)
    system.description = PRESET_TABLE["two-arm"].description
    system.robot = paper_two_arm()
    return system


PRESETS = {"one-arm": one_arm, "two-arm": two_arm}


@cache
def preset(name: str) -> System:
    """A preset model by name; one shared instance, so its numeric functions compile once."""
    return PRESETS[name]()
