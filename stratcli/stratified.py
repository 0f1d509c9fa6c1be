"""Stratified planning: a sequence of legs, each on its stratum, concatenated (paper §5.1-5.2).

Legs are planned in order; each starts at the configuration the previous one actually
reached, and its boundary conditions take the previous leg's final control values (DESIGN §3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .continuity import MODES, eliminate, leg_constraints
from .controls import FourierBasis, energy
from .endpoint import make_endpoint
from .errors import InputError, Problem
from .models.system import System
from .planners.newton import NewtonSettings, plan_leg


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
    coefficients: np.ndarray  # (m_active, 2H+1)
    error: float
    iterations: int
    attempts: int
    energy: float
    converged: bool
    free_coefficients: int

    def controls(self, basis: FourierBasis, t: np.ndarray, m: int, derivative: bool = False):
        """All m inputs at leg-local times t, shape (len(t), m); inactive inputs are zero."""
        phi = basis.derivatives(t) if derivative else basis.values(t)
        out = np.zeros((np.size(t), m))
        out[:, list(self.active)] = np.atleast_2d(phi) @ self.coefficients.T
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

    @property
    def ok(self) -> bool:
        return (
            self.planned_legs > 0
            and all(leg.converged for leg in self.legs)
            and (len(self.legs) == self.planned_legs)
        )

    @property
    def total_energy(self) -> float:
        return float(sum(leg.energy for leg in self.legs))

    @property
    def duration(self) -> float:
        return float(sum(leg.duration for leg in self.legs))


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
        cons = leg_constraints(
            settings.basis,
            leg.duration,
            stratum.active,
            system.inputs,
            settings.continuity,
            previous=None if i == 0 else (np.zeros(system.m), np.zeros(system.m)),
            next_active=next_active,
            soft_start=settings.soft_start,
            full_stop=settings.full_stop,
        )
        free = eliminate(cons).free
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


def _targets(system: System, stratum, leg: LegSpec) -> tuple[int, ...]:
    return tuple(i for i in stratum.free(system.n) if i not in leg.free)


def plan_sequence(
    system: System, start: np.ndarray, legs: list[LegSpec], settings: PlannerSettings
) -> PlanResult:
    """Plan all legs in order with the concatenation conditions of `settings.continuity`."""
    start = np.asarray(start, dtype=float)
    check_legs(system, start, legs, settings)
    basis = settings.basis
    result = PlanResult(system, settings, start, legs[-1].goal.copy(), planned_legs=len(legs))
    q = start.copy()
    t0 = 0.0
    previous = None
    newton = NewtonSettings(
        settings.tolerance, settings.max_iterations, settings.restarts, settings.seed
    )
    for i, leg in enumerate(legs):
        stratum = system.stratum(leg.stratum)
        cs = system.compiled(stratum)
        endpoint = make_endpoint(cs, q, basis, leg.duration, settings.evaluator)
        next_active = None if i + 1 == len(legs) else system.stratum(legs[i + 1].stratum).active
        elimination = eliminate(
            leg_constraints(
                basis,
                leg.duration,
                stratum.active,
                system.inputs,
                settings.continuity,
                previous=previous,
                next_active=next_active,
                soft_start=settings.soft_start,
                full_stop=settings.full_stop,
            )
        )
        targets = np.array(_targets(system, stratum, leg), dtype=int)
        solution = plan_leg(endpoint, leg.goal, targets, elimination, newton, stream=i)
        leg_result = LegResult(
            index=i,
            stratum=stratum.name,
            method=leg.method,
            evaluator=endpoint.kind,
            active=stratum.active,
            locked=stratum.locked,
            targets=tuple(targets.tolist()),
            t0=t0,
            duration=leg.duration,
            start=q.copy(),
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
        if result.legs:
            prev_leg = result.legs[-1]
            result.switches.append(
                Switch(
                    time=t0,
                    after_leg=prev_leg.index,
                    jump=leg_result.controls(basis, np.array([0.0]), system.m)[0] - previous[0],
                    jump_derivative=leg_result.controls(basis, np.array([0.0]), system.m, True)[0]
                    - previous[1],
                )
            )
        result.legs.append(leg_result)
        if not solution.converged:
            result.message = (
                f"leg {i + 1} on {stratum.name} did not reach its goal: error "
                f"{solution.error:.3g} > tolerance {settings.tolerance:.3g} after "
                f"{solution.iterations} iterations in {solution.attempts} attempts; try more "
                "harmonics (planner.basis.harmonics), a longer leg, or a via configuration "
                "closer to the start"
            )
            break
        T = np.array([leg.duration])
        previous = (
            leg_result.controls(basis, T, system.m)[0],
            leg_result.controls(basis, T, system.m, True)[0],
        )
        q = solution.end.copy()
        t0 += leg.duration
    return result
