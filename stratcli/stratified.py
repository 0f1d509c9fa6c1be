"""Stratified planning: a sequence of legs, each on its stratum, concatenated (paper §5.1-5.2).

Legs are planned in order; each starts at the configuration the previous one actually
reached, and its boundary conditions take the previous leg's final control values (DESIGN §3).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .continuity import MODES, eliminate, leg_constraints
from .controls import FourierBasis, energy
from .endpoint import make_endpoint
from .errors import InputError, Problem
from .models.system import System
from .planners.lie import LieSettings, plan_lie_leg
from .planners.newton import NewtonSettings, plan_leg

SEED_RESTARTS = 2  # Newton restarts allowed for the extra starts of the energy objective


@dataclass(frozen=True)
class PlannerSettings:
    continuity: str = "lr-C1"
    soft_start: bool = False
    full_stop: bool = False
    tolerance: float = 1e-3
    basis: FourierBasis = FourierBasis()
    max_iterations: int = 100
    restarts: int = 11
    seed: int = 0
    evaluator: str = "auto"  # "auto" | "quadrature" | "ode"
    objective: str = "energy"  # "energy" (minimum ∫|u|², beyond the paper) | "newton" (paper)
    starts: int = 6  # energy objective: number of deterministic starts
    lie: LieSettings = LieSettings()  # defaults of the legs planned with method "lie"

    def __post_init__(self) -> None:
        if self.continuity not in MODES:
            raise ValueError(f"unknown continuity mode {self.continuity!r}")


@dataclass(frozen=True)
class LegSpec:
    """One leg of the task: the stratum, the method and the configuration to reach."""

    stratum: str
    goal: np.ndarray  # NaN where the end value is not prescribed ("*" in a scenario)
    method: str = "newton"
    duration: float = 1.0
    lie: LieSettings | None = None  # method "lie": overrides PlannerSettings.lie

    @property
    def free(self) -> tuple[int, ...]:
        """Coordinates whose end value is left to the planner."""
        return tuple(np.flatnonzero(np.isnan(self.goal)).tolist())


@dataclass
class LegResult:
    index: int
    stratum: str
    method: str
    evaluator: str
    active: tuple[int, ...]
    locked: tuple[int, ...]
    targets: tuple[int, ...]
    t0: float
    duration: float
    start: np.ndarray
    goal: np.ndarray
    end: np.ndarray
    coefficients: np.ndarray  # (m_active, 2H+1); a multi-piece leg: (pieces, m_active, 2H+1)
    error: float
    iterations: int
    attempts: int
    energy: float
    converged: bool
    free_coefficients: int
    pieces: list | None = None  # Lie legs: planners.lie.LiePiece (t0, duration, coefficients)

    def piece_list(self) -> list[tuple[float, float, np.ndarray]]:
        """(leg-local t0, duration, coefficients (m_active, 2H+1)) of every piece; a Newton leg
        is one piece. Each piece's controls use its own local time, starting at 0."""
        if self.pieces is None:
            return [(0.0, self.duration, self.coefficients)]
        return [(p.t0, p.duration, p.coefficients) for p in self.pieces]

    def controls(self, basis: FourierBasis, t: np.ndarray, m: int, derivative: bool = False):
        """All m inputs at leg-local times t, shape (len(t), m); inactive inputs are zero.

        Piece-aware: at a joint between two pieces the later piece is used (the pieces join
        continuously as the continuity mode promises); at the leg's end, the last piece.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((t.size, m))
        pieces = self.piece_list()
        starts = np.array([p[0] for p in pieces])
        which = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(pieces) - 1)
        for k, (t0, _, L) in enumerate(pieces):
            sel = which == k
            if sel.any():
                local = t[sel] - t0
                phi = basis.derivatives(local) if derivative else basis.values(local)
                out[np.ix_(sel, list(self.active))] = np.atleast_2d(phi) @ np.asarray(L).T
        return out


@dataclass
class Switch:
    time: float
    after_leg: int
    jump: np.ndarray  # (m,) value jumps u_next(0) - u_prev(T)
    jump_derivative: np.ndarray


@dataclass
class PlanResult:
    system: System
    settings: PlannerSettings
    start: np.ndarray
    goal: np.ndarray
    legs: list[LegResult] = field(default_factory=list)
    switches: list[Switch] = field(default_factory=list)
    planned_legs: int = 0
    message: str = ""
    optimisation: object | None = None  # planners.energy.EnergyOptimum for objective "energy"
    time_scale: float = 1.0
    notes: list[str] = field(default_factory=list)  # e.g. why the energy objective was not used

    @property
    def ok(self) -> bool:
        return (
            self.planned_legs > 0
            and all(leg.converged for leg in self.legs)
            and (len(self.legs) == self.planned_legs)
        )

    def add_leg(self, leg: LegResult, previous: tuple[np.ndarray, np.ndarray] | None) -> None:
        """Append a planned leg; record the switch from the previous one (whose final control
        values and derivatives are `previous`), and the failure message if it failed."""
        if self.legs:
            zero, basis, m = np.array([0.0]), self.settings.basis, self.system.m
            self.switches.append(
                Switch(
                    leg.t0,
                    self.legs[-1].index,
                    leg.controls(basis, zero, m)[0] - previous[0],
                    leg.controls(basis, zero, m, True)[0] - previous[1],
                )
            )
        self.legs.append(leg)
        if not leg.converged:
            self.message = failure_message(leg, self.settings)

    @property
    def total_energy(self) -> float:
        return float(sum(leg.energy for leg in self.legs))

    @property
    def duration(self) -> float:
        return float(sum(leg.duration for leg in self.legs))


def _check_lie_leg(system, settings, leg, i, stratum, targets, next_active) -> list[Problem]:
    """A Lie step must leave enough free coefficients to solve `h(λ) = α` (eq. 23) for all
    Hall coordinates; every step has the leg's start (continuity) and end conditions."""
    from .lie import hall_basis

    lie = leg.lie or settings.lie
    r = max(len(hall_basis(len(stratum.active), lie.degree)), len(targets))
    free = None
    starts = [(np.zeros(system.m), np.zeros(system.m))]
    if i == 0:
        starts.append(None)  # the very first step: soft start instead of continuity
    for previous in starts:
        cons = leg_constraints(
            settings.basis,
            lie.step_duration,
            stratum.active,
            system.inputs,
            settings.continuity,
            previous=previous,
            next_active=next_active,
            soft_start=settings.soft_start and previous is None,
            full_stop=(settings.full_stop and next_active is None) or lie.rest,
        )
        f = eliminate(cons).free
        free = f if free is None else min(free, f)
    if free >= r:
        return []
    return [
        Problem(
            f"legs[{i}]",
            f"leg {i + 1} on {leg.stratum} (method lie): the boundary conditions of a step "
            f"leave {free} free coefficients for the {r} coordinates of the Hall basis "
            f"(degree {lie.degree}): {r - free} missing; raise planner.basis.harmonics",
        )
    ]


def check_legs(system: System, start: np.ndarray, legs: list[LegSpec], settings: PlannerSettings):
    """Problems found before planning: locked coordinates asked to move, too few coefficients."""
    problems: list[Problem] = []
    previous = np.asarray(start, dtype=float)
    for i, leg in enumerate(legs):
        stratum = system.stratum(leg.stratum)
        for k in stratum.locked:
            if np.isnan(leg.goal[k]) or np.isnan(previous[k]):
                continue  # not prescribed, or only known once the previous leg is planned
            if abs(leg.goal[k] - previous[k]) > 1e-9:
                problems.append(
                    Problem(
                        f"legs[{i}].goal",
                        f"leg {i + 1} on {leg.stratum}: {system.states[k]} is locked at "
                        f"{previous[k]:.6g} on this stratum but its goal is {leg.goal[k]:.6g}; "
                        f"use a stratum that moves {system.states[k]} or keep it at "
                        f"{previous[k]:.6g}",
                    )
                )
        targets = _targets(system, stratum, leg)
        next_active = None if i + 1 == len(legs) else system.stratum(legs[i + 1].stratum).active
        if leg.method == "lie":
            problems += _check_lie_leg(system, settings, leg, i, stratum, targets, next_active)
            unlocked = np.isin(np.arange(system.n), stratum.locked, invert=True)
            previous = np.where(unlocked, leg.goal, previous)
            continue
        previous_controls = None if i == 0 else (np.zeros(system.m), np.zeros(system.m))
        free = _leg_elimination(system, settings, leg, previous_controls, next_active).free
        if free < len(targets):
            problems.append(
                Problem(
                    f"legs[{i}]",
                    f"leg {i + 1} on {leg.stratum}: the boundary conditions "
                    f"({settings.continuity}{', soft start' if settings.soft_start else ''}"
                    f"{', full stop' if settings.full_stop else ''}) leave {free} free "
                    f"coefficients for {len(targets)} goal coordinates: "
                    f"{len(targets) - free} missing; raise planner.basis.harmonics",
                )
            )
        unlocked = np.isin(np.arange(system.n), stratum.locked, invert=True)
        previous = np.where(unlocked, leg.goal, previous)
    if problems:
        raise InputError(problems)


def _leg_elimination(
    system: System, settings: PlannerSettings, leg: LegSpec, previous, next_active
):
    """The boundary conditions of a Newton leg (continuity with `previous` controls, or soft
    start on the first leg; lr-continuity into `next_active`, or full stop on the last),
    eliminated: the free coefficients the planner works in."""
    return eliminate(
        leg_constraints(
            settings.basis,
            leg.duration,
            system.stratum(leg.stratum).active,
            system.inputs,
            settings.continuity,
            previous=previous,
            next_active=next_active,
            soft_start=settings.soft_start,
            full_stop=settings.full_stop,
        )
    )


def _targets(system: System, stratum, leg: LegSpec) -> tuple[int, ...]:
    return tuple(i for i in stratum.free(system.n) if i not in leg.free)


def plan_sequence(
    system: System,
    start: np.ndarray,
    legs: list[LegSpec],
    settings: PlannerSettings,
    warm_start: list[np.ndarray] | None = None,
) -> PlanResult:
    """Plan a sequence of legs with the settings' objective.

    `newton`: the paper's method, leg by leg. `energy`: Newton first (a feasible plan), then
    the minimum-energy controls over all legs together from `settings.starts` deterministic
    starts, then a final leg-by-leg pass that re-chains the legs from the configurations they
    actually reach (Newton polishes a leg only if it is off by more than the tolerance).
    `warm_start` (flat coefficients per leg, feasible) is tried as an extra first start.
    """
    start = np.asarray(start, dtype=float)
    check_legs(system, start, legs, settings)  # once: the passes below plan the same legs
    lie_legs = [i + 1 for i, leg in enumerate(legs) if leg.method == "lie"]
    if lie_legs and settings.objective != "newton":
        return _with_lie_legs(system, start, legs, settings, lie_legs)
    newton = _plan_legs(system, start, legs, settings)
    if settings.objective == "newton" or not newton.ok:
        return newton
    from .planners.energy import optimise_energy

    # Starts: the Newton plan, then Newton plans from more widely perturbed seeded starts
    # (cheap, feasible, and in different basins: energy varies by orders of magnitude).
    seeds = [newton]
    quick = replace(settings, restarts=min(settings.restarts, SEED_RESTARTS))
    for k in range(1, settings.starts):
        other = _plan_legs(system, start, legs, quick, seed=settings.seed + 7919 * k,
                           spread=0.02 + 0.3 * k)  # fmt: skip
        if other.ok:  # a seed that needs many restarts is not worth its time: skip it
            seeds.append(other)
    nominal = [start]
    for leg, planned in zip(legs[:-1], newton.legs[:-1], strict=True):
        nominal.append(np.where(np.isnan(leg.goal), planned.end, leg.goal))
    targets = [np.array(leg.targets, dtype=int) for leg in newton.legs]
    stacked = [
        ("newton", np.concatenate([leg.coefficients.ravel() for leg in p.legs])) for p in seeds
    ]
    if warm_start is not None:
        stacked.insert(0, ("warm start", np.concatenate([np.ravel(c) for c in warm_start])))
    optimum = optimise_energy(system, nominal, legs, settings, targets, stacked)
    optimum.newton_energy = newton.total_energy
    newton.optimisation = optimum
    if optimum.coefficients is None:
        return newton
    final = _plan_legs(system, start, legs, settings, initial=optimum.coefficients)
    final.optimisation = optimum
    return final if final.ok and final.total_energy <= newton.total_energy else newton


def _with_lie_legs(system, start, legs, settings, lie_legs) -> PlanResult:
    """The energy objective for a sequence with Lie legs, which it cannot optimise itself.

    Lie legs are built step by step from where the system actually is, so there is no fixed
    set of their coefficients to optimise jointly: the sequence is planned leg by leg. The
    Newton legs of that pass are seeded with the minimum-energy plan of the same sequence
    with a Newton stand-in for every Lie leg (Newton legs after a Lie leg are re-polished
    from where it ends; Lie legs are planned as usual). If that fails, the plain leg-by-leg
    plan (the paper's Newton method) is returned. A note says which.
    """
    stand_in = [replace(leg, method="newton") if leg.method == "lie" else leg for leg in legs]
    which = ", ".join(map(str, lie_legs))
    if len(lie_legs) == len(legs):
        plain = _plan_legs(system, start, legs, settings)
        plain.notes.append(
            f"objective {settings.objective!r} does not apply: every leg uses the "
            "Lie-algebraic method (local steps of least energy, planned where the system is)"
        )
        return plain
    try:
        proxy = plan_sequence(system, start, stand_in, settings)
    except (ValueError, np.linalg.LinAlgError):  # the stand-in is only a helper
        proxy = None
    if proxy is not None and proxy.ok and proxy.optimisation is not None:
        initial = [np.ravel(leg.coefficients) for leg in proxy.legs]
        seeded = _plan_legs(system, start, legs, settings, initial=initial)
        if seeded.ok:
            seeded.notes.append(
                f"objective {settings.objective!r} applied to the Newton legs only: leg(s) "
                f"{which} use the Lie-algebraic method (local steps, planned where the system "
                "is); the Newton legs come from the minimum-energy plan with a Newton "
                "stand-in for each Lie leg, then the sequence was planned leg by leg"
            )
            return seeded
    plain = _plan_legs(system, start, legs, settings)
    plain.notes.append(
        f"objective {settings.objective!r} not applied: leg(s) {which} use the Lie-algebraic "
        "method, so the sequence was planned leg by leg (Newton legs with the paper's Newton "
        "method)"
    )
    return plain


def time_scaled(plan: PlanResult, s: float) -> PlanResult:
    """The same path run `s` times faster (paper §6): `u(t) → s·u(s·t)`.

    Durations and switch times are divided by `s`, the basis period too (so every piece is
    still a Fourier series of the documented form), coefficients are multiplied by `s`;
    energies grow by `s`, value jumps by `s` and derivative jumps by `s²`.
    """
    basis = FourierBasis(plan.settings.basis.harmonics, plan.settings.basis.period / s)
    legs = [
        replace(
            leg,
            t0=leg.t0 / s,
            duration=leg.duration / s,
            coefficients=leg.coefficients * s,
            energy=energy(basis, leg.duration / s, leg.coefficients * s),
        )
        if leg.pieces is None
        else _scaled_pieces(leg, basis, s)
        for leg in plan.legs
    ]
    switches = [
        Switch(sw.time / s, sw.after_leg, sw.jump * s, sw.jump_derivative * s * s)
        for sw in plan.switches
    ]
    out = replace(plan, legs=legs, switches=switches, settings=replace(plan.settings, basis=basis))
    out.time_scale = plan.time_scale * s
    return out


def _scaled_pieces(leg: LegResult, basis: FourierBasis, s: float) -> LegResult:
    """`time_scaled` for a multi-piece (Lie) leg: every piece scaled like a whole leg."""
    pieces = [
        replace(p, t0=p.t0 / s, duration=p.duration / s, coefficients=p.coefficients * s)
        for p in leg.pieces
    ]
    return replace(
        leg,
        t0=leg.t0 / s,
        duration=leg.duration / s,
        coefficients=leg.coefficients * s,
        energy=float(sum(energy(basis, p.duration, p.coefficients) for p in pieces)),
        pieces=pieces,
    )


def plan_one_leg(
    system: System,
    settings: PlannerSettings,
    q: np.ndarray,
    previous: tuple[np.ndarray, np.ndarray] | None,
    leg: LegSpec,
    index: int,
    next_active: tuple[int, ...] | None,
    t0: float,
    newton: NewtonSettings,
    initial: np.ndarray | None = None,
) -> LegResult:
    """Plan leg `index` from configuration `q`.

    `previous` holds all inputs' values and derivatives at the end of the previous leg (None
    for the first leg); `next_active` the next leg's inputs (None for the last leg).
    """
    if leg.method == "lie":
        return _plan_lie(system, settings, q, previous, leg, index, next_active, t0, newton.seed)
    basis = settings.basis
    stratum = system.stratum(leg.stratum)
    endpoint = make_endpoint(system.compiled(stratum), q, basis, leg.duration, settings.evaluator)
    elimination = _leg_elimination(system, settings, leg, previous, next_active)
    targets = np.array(_targets(system, stratum, leg), dtype=int)
    solution = plan_leg(
        endpoint, leg.goal, targets, elimination, newton, stream=index, initial=initial
    )
    return LegResult(
        index=index,
        stratum=stratum.name,
        method=leg.method,
        evaluator=endpoint.kind,
        active=stratum.active,
        locked=stratum.locked,
        targets=tuple(targets.tolist()),
        t0=t0,
        duration=leg.duration,
        start=np.array(q, dtype=float),
        goal=np.asarray(leg.goal, dtype=float).copy(),
        end=solution.end.copy(),
        coefficients=solution.coefficients,
        error=solution.error,
        iterations=solution.iterations,
        attempts=solution.attempts,
        energy=energy(basis, leg.duration, solution.coefficients),
        converged=solution.converged,
        free_coefficients=elimination.free,
    )


def _plan_lie(system, settings, q, previous, leg, index, next_active, t0, seed) -> LegResult:
    """A leg with the Lie-algebraic method: one piece per local step (planners.lie)."""
    stratum = system.stratum(leg.stratum)
    lie = leg.lie or settings.lie
    targets = np.array(_targets(system, stratum, leg), dtype=int)
    sol = plan_lie_leg(
        system,
        stratum.name,
        q,
        leg.goal,
        targets,
        settings.basis,
        lie,
        tolerance=settings.tolerance,
        mode=settings.continuity,
        previous=previous,
        next_active=next_active,
        soft_start=settings.soft_start and previous is None,
        full_stop=settings.full_stop and next_active is None,
        evaluator=settings.evaluator,
        seed=seed,
        stream=index,
    )
    cs = system.compiled(stratum)
    return LegResult(
        index=index,
        stratum=stratum.name,
        method=leg.method,
        evaluator=make_endpoint(cs, q, settings.basis, lie.step_duration, settings.evaluator).kind,
        active=stratum.active,
        locked=stratum.locked,
        targets=tuple(targets.tolist()),
        t0=t0,
        duration=len(sol.pieces) * lie.step_duration,
        start=np.array(q, dtype=float),
        goal=np.asarray(leg.goal, dtype=float).copy(),
        end=sol.end.copy(),
        coefficients=np.stack([p.coefficients for p in sol.pieces]),
        error=sol.error,
        iterations=sol.steps,
        attempts=1,
        energy=sol.energy,
        converged=sol.converged,
        free_coefficients=sol.free_coefficients,
        pieces=sol.pieces,
    )


def failure_message(leg: LegResult, settings: PlannerSettings) -> str:
    """What a user reads when a leg does not converge: which leg, how far off, what to try."""
    if leg.method == "lie":
        return (
            f"leg {leg.index + 1} on {leg.stratum} (Lie-algebraic) did not reach its goal: "
            f"error {leg.error:.3g} > tolerance {settings.tolerance:.3g} after {leg.iterations} "
            "steps; try a smaller lie.gamma, lie.degree = 3, more lie.max_steps, a goal "
            'closer to the start (the method is local), or method = "newton"'
        )
    return (
        f"leg {leg.index + 1} on {leg.stratum} did not reach its goal: error "
        f"{leg.error:.3g} > tolerance {settings.tolerance:.3g} after "
        f"{leg.iterations} iterations in {leg.attempts} attempts; try more "
        "harmonics (planner.basis.harmonics), a longer leg, or a via configuration "
        "closer to the start"
    )


def end_controls(leg: LegResult, basis: FourierBasis, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Values and derivatives of all m inputs at the end of a leg (the next leg's start)."""
    T = np.array([leg.duration])
    return leg.controls(basis, T, m)[0], leg.controls(basis, T, m, True)[0]


def _plan_legs(
    system: System,
    start: np.ndarray,
    legs: list[LegSpec],
    settings: PlannerSettings,
    initial: list[np.ndarray] | None = None,
    seed: int | None = None,
    spread: float = 0.02,
) -> PlanResult:
    """Plan all legs in order with the concatenation conditions of `settings.continuity`.

    `initial` (flat coefficients per leg) seeds each leg's first Newton start; a leg that is
    already within tolerance then takes no iteration.
    """
    start = np.asarray(start, dtype=float)
    basis = settings.basis
    result = PlanResult(system, settings, start, legs[-1].goal.copy(), planned_legs=len(legs))
    q = start.copy()
    t0 = 0.0
    previous = None
    newton = NewtonSettings(
        settings.tolerance,
        settings.max_iterations,
        settings.restarts,
        settings.seed if seed is None else seed,
        spread,
    )
    for i, leg in enumerate(legs):
        next_active = None if i + 1 == len(legs) else system.stratum(legs[i + 1].stratum).active
        leg_result = plan_one_leg(
            system,
            settings,
            q,
            previous,
            leg,
            i,
            next_active,
            t0,
            newton,
            None if initial is None else initial[i],
        )
        result.add_leg(leg_result, previous)
        if not leg_result.converged:
            break
        previous = end_controls(leg_result, basis, system.m)
        q = leg_result.end.copy()
        t0 += leg_result.duration  # a Lie leg lasts (steps) x (step duration)
    return result
