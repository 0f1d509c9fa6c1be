"""Planner settings: one frozen model per concern, the scenario's tables *and* the engine's input.

Every default lives here and only here. The classes are pydantic dataclasses: they validate
on construction (also from Python and under `dataclasses.replace`), pickle, hash, and are
what the scenario schema embeds (`[planner]`, `[planner.basis]`, `[planner.lie]`,
`[decompose]`). Types are strict (`"3"` is not an integer, `"yes"` not a boolean) and every
number is finite and range-checked where the numerics bound it, so that no setting can make
the planner hang or overflow.
"""

from __future__ import annotations

from typing import Annotated, Literal, get_args

from pydantic import Field, Strict
from pydantic.dataclasses import dataclass

from .controls import CONFIG, FourierBasis

__all__ = [
    "CONFIG",
    "CONTINUITY_MODES",
    "DecomposeSettings",
    "FourierBasis",
    "LieSettings",
    "PlannerSettings",
]

CONTINUITY_MODES = ("none", "l-C0", "l-C1", "lr-C0", "lr-C1")
Continuity = Literal["none", "l-C0", "l-C1", "lr-C0", "lr-C1"]

Int = Annotated[int, Strict()]
Float = Annotated[float, Strict()]  # ints are accepted as floats, strings are not
Bool = Annotated[bool, Strict()]

# Documented limits (README, "Scenario format"): outside them the numerics are meaningless
# or unbounded in work (a 1e308 duration overflows the Gram matrix, a 1e-12 period asks for
# ~1e12 quadrature nodes).
MAX_DURATION = 1e3  # s, one leg
MIN_DURATION = 1e-3
MAX_TIME_SCALE = 1e3


@dataclass(frozen=True, config=CONFIG)
class LieSettings:
    """The Lie-algebraic method (legs with ``method = "lie"``, paper §4.2, eq. 21-24).

    Attributes
    ----------
    step_duration : length of one local step, s (the paper's 0.51).
    gamma : fraction of the remaining error asked of one step.
    degree : Philip Hall basis degree (brackets up to this order): 1, 2 or 3.
    max_steps : steps before the leg gives up.
    alpha : "energy" (least-energy step, eq. 22 and 23 together) or "pinv" (the paper's
        two-stage pseudo-inverse).
    rest : every step ends with ``u = u' = 0`` (self-contained loops).
    """

    step_duration: Annotated[Float, Field(ge=MIN_DURATION, le=MAX_DURATION)] = 0.51
    gamma: Annotated[Float, Field(gt=0, le=1)] = 0.5
    degree: Annotated[Int, Field(ge=1, le=3)] = 2
    max_steps: Annotated[Int, Field(ge=1, le=1000)] = 40
    alpha: Literal["energy", "pinv"] = "energy"
    rest: Bool = True


Search = Literal["loops", "starts", "legwise"]  # the energy search (`PlannerSettings.search`)
SEARCHES = get_args(Search)


@dataclass(frozen=True, config=CONFIG)
class PlannerSettings:
    """How every leg is planned (scenario table ``[planner]``).

    Attributes
    ----------
    continuity : concatenation conditions at switches: none, l-C0, l-C1, lr-C0,
        lr-C1.
    soft_start, full_stop : ``u = u' = 0`` at the very start / end of the sequence.
    tolerance : goal error (Euclidean over the coordinates a leg steers) counted as reached.
    leg_duration : duration of a Newton leg that does not give its own, s.
    basis : the Fourier control basis (paper eq. 30).
    max_iterations, restarts, seed : Newton iterations per attempt, extra seeded attempts,
        and the seed of every random choice.
    evaluator : end-point map: "auto" (quadrature where the structure allows; Magnus on URDF
        models), "quadrature", "ode", "magnus" (URDF models only).
    objective : "energy" (minimum ∫|u|² over all legs, beyond the paper) or "newton" (the
        paper's method, leg by leg).
    starts : deterministic starts of the energy search: the Newton plan pulled toward least
        energy, the Newton plan, then Newton plans from seeded starts. Legs without exact
        second derivatives (URDF and ODE-path legs) have no pulled start: the Newton plan
        comes first, then on URDF robots in its place the lowest legs (each leg's
        lowest-energy of six Newton plans, `newton_starts`), left out with 1.
    search : "loops" (the default): after those starts, *loop starts* where a leg's loop could
        run round a nearer peak of the base's curvature, raced on their own (`planners.loops`;
        a few milliseconds a leg where none qualifies); "starts": those starts only (the
        search of records made before loop starts); "legwise": the loop starts and one more,
        made from each leg's lowest minimum on its own, joined by continuation in the switch
        conditions (`planners.legwise`; a global strategy, at several times the cost).
    constrained_starts : with [constraints] limits the search needs, how many starts must get
        inside them before the lowest energy is kept: 1, the first that does (the plan
        itself, then Newton plans from seeds); more, further seeded Newton plans, each a
        constrained search of its own (several times the cost, often far lower energies).
    time_scale : run the planned path this many times faster after planning (paper §6).
    lie : defaults of the legs planned with the Lie-algebraic method.
    durations : "fixed" (each leg's own duration) or "optimise": the energy objective also
        chooses how `total_duration` is shared among the legs (`stratcli.durations`).
    total_duration : the time budget of "optimise", s (default: the sum of the legs' own).
    """

    continuity: Continuity = "lr-C1"
    soft_start: Bool = False
    full_stop: Bool = False
    tolerance: Annotated[Float, Field(ge=1e-12, le=1.0)] = 1e-3
    leg_duration: Annotated[Float, Field(ge=MIN_DURATION, le=MAX_DURATION)] = 1.0
    basis: FourierBasis = FourierBasis()
    max_iterations: Annotated[Int, Field(ge=1, le=10_000)] = 100
    restarts: Annotated[Int, Field(ge=0, le=1000)] = 11
    seed: Annotated[Int, Field(ge=0, lt=2**63)] = 0
    evaluator: Literal["auto", "quadrature", "ode", "magnus"] = "auto"
    objective: Literal["energy", "newton"] = "energy"
    starts: Annotated[Int, Field(ge=1, le=64)] = 2
    search: Search = "loops"
    constrained_starts: Annotated[Int, Field(ge=1, le=16)] = 1
    time_scale: Annotated[Float, Field(ge=1.0 / MAX_TIME_SCALE, le=MAX_TIME_SCALE)] = 1.0
    lie: LieSettings = LieSettings()
    durations: Literal["fixed", "optimise"] = "fixed"
    total_duration: Annotated[Float, Field(ge=MIN_DURATION, le=100 * MAX_DURATION)] | None = None


@dataclass(frozen=True, config=CONFIG)
class DecomposeSettings:
    """Auto mode (paper §5.3, scenario table ``[decompose]``): stratplan finds the sequences.

    Attributes
    ----------
    max_length : longest candidate sequence of strata.
    strategy : vias "conservative", "postponed" or "both".
    criterion : ranking: "energy", "peak-control", "excursion" or "duration".
    strata : candidate strata (default: every stratum of the model).
    """

    max_length: Annotated[Int, Field(ge=1, le=8)] = 3
    strategy: Literal["conservative", "postponed", "both"] = "conservative"
    criterion: Literal["energy", "peak-control", "excursion", "duration"] = "energy"
    strata: Annotated[tuple[str, ...], Field(min_length=1)] | None = None


# pydantic's name for a key the dataclass does not know (models say "extra_forbidden")
UNKNOWN_KEY_ERRORS = ("extra_forbidden", "unexpected_keyword_argument")
