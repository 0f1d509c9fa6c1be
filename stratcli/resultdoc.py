"""`result.json` (schema "stratplan.result/1") to and from a `SequencePlan`, with no I/O.

A contract: with the document alone anyone can rebuild every control
`u_k(t) = λ0 + Σ_i λi sin(2iπt/P) + λ_{i+H} cos(2iπt/P)` (piece-local time `t ∈ [0,
duration]`) and re-integrate the model from `start`. Coordinates not prescribed by a goal are
`null`. `plan_from_document(plan_document(p))` gives back a plan whose document is the same.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from .constraint_report import ConstraintReport
from .controls import FourierBasis
from .results import (
    SCHEMA,
    LegPlan,
    ModelRef,
    Optimisation,
    Piece,
    StartOutcome,
    Switch,
    finite_or_none,
    nan_to_none,
    none_to_nan,
)
from .settings import PlannerSettings
from .status import Status

if TYPE_CHECKING:  # documents are made from, and into, the plan type that uses this module
    from .sequence import SequencePlan

_START_KEYS = {
    "index": "index",
    "from": "kind",
    "energy": "energy",
    "goal_error": "goal_error",
    "projected_gradient": "projected_gradient",
    "iterations": "iterations",
    "converged": "converged",
    "stopped": "stopped",
    "seconds": "seconds",
    "feasible": "feasible",  # absent in records before 0.1's last release: then `converged`
}


def _optimisation(opt: Optimisation | None) -> dict[str, Any] | None:
    if opt is None:
        return None
    return {
        "method": opt.method,
        "best": opt.best,
        "newton_energy": opt.newton_energy,
        "search": opt.search,
        "no_loop_start": opt.no_loop_start,
        "starts": [{k: getattr(s, a) for k, a in _START_KEYS.items()} for s in opt.starts],
    }


def _leg(plan: SequencePlan, leg: LegPlan) -> dict[str, Any]:
    basis = {"kind": "fourier", "harmonics": leg.basis.harmonics, "period": leg.basis.period}
    return {
        "stratum": leg.stratum,
        "method": leg.method,
        "evaluator": leg.evaluator,
        "active_inputs": [plan.inputs[k] for k in leg.active],
        "locked": [plan.coordinates[k] for k in leg.locked],
        "targets": [plan.coordinates[k] for k in leg.targets],
        "t0": leg.t0,
        "duration": leg.duration,
        "start": nan_to_none(leg.start),
        "goal": nan_to_none(leg.goal),
        "end": nan_to_none(leg.end),
        "error": finite_or_none(leg.error),
        "converged": leg.converged,
        "status": leg.status.key,
        "iterations": leg.iterations,
        "attempts": leg.attempts,
        "strategy": leg.strategy,
        "free_coefficients": leg.free_coefficients,
        "energy": finite_or_none(leg.energy),
        "pieces": [  # a Newton leg is one piece; a Lie leg one piece per step
            {
                "t0": p.t0,
                "duration": p.duration,
                "basis": dict(basis),
                "coefficients": {
                    plan.inputs[k]: p.coefficients[a].tolist() for a, k in enumerate(leg.active)
                },
            }
            for p in leg.pieces
        ],
    }


def plan_document(plan: SequencePlan) -> dict[str, Any]:
    """The JSON-ready result of a planned (or failed) sequence; a spatial (URDF) plan also
    has an `attitude` section (`spatialdoc`)."""
    doc = _document(plan)
    if getattr(plan.model.spec, "kind", None) == "urdf":
        from .spatialdoc import attitude_document

        doc["attitude"] = attitude_document(plan)
    return doc


def _document(plan: SequencePlan) -> dict[str, Any]:
    s = plan.settings
    return {
        "schema": SCHEMA,
        "scenario": plan.scenario,
        "status": "ok" if plan.ok else "failed",
        "message": plan.message,
        "model": plan.model.name,
        "coordinates": list(plan.coordinates),
        "inputs": list(plan.inputs),
        "start": nan_to_none(plan.start),
        "goal": nan_to_none(plan.goal),
        "end": nan_to_none(plan.end) if plan.legs else None,
        "total_energy": finite_or_none(plan.total_energy),
        "reference_energy": plan.reference_energy,
        "duration": plan.duration,
        "planned_legs": plan.planned_legs,
        "continuity": s.continuity,
        "soft_start": s.soft_start,
        "full_stop": s.full_stop,
        "tolerance": s.tolerance,
        "seed": s.seed,
        "objective": s.objective,
        "time_scale": plan.time_scale,
        "notes": list(plan.notes),
        "optimisation": _optimisation(plan.optimisation),
        "constraints": plan.constraints.to_dict() if plan.constraints else None,
        "legs": [_leg(plan, leg) for leg in plan.legs],
        "switches": [
            {
                "time": sw.time,
                "after_leg": sw.after_leg,
                "jump": dict(zip(plan.inputs, nan_to_none(sw.jump), strict=True)),
                "jump_derivative": dict(
                    zip(plan.inputs, nan_to_none(sw.jump_derivative), strict=True)
                ),
            }
            for sw in plan.switches
        ],
    }


def _vector(values: list[float | None] | None) -> np.ndarray:
    return none_to_nan(values or [])


def _leg_from(doc: dict, i: int, coordinates: list[str], inputs: list[str]) -> LegPlan:
    first = doc["pieces"][0]["basis"] if doc["pieces"] else {"harmonics": 3, "period": 2.17}
    basis = FourierBasis(int(first["harmonics"]), float(first["period"]))
    active = tuple(inputs.index(u) for u in doc["active_inputs"])
    pieces = tuple(
        Piece(
            p["t0"],
            p["duration"],
            np.array([p["coefficients"][inputs[k]] for k in active], dtype=float),
        )
        for p in doc["pieces"]
    )
    locked = tuple(coordinates.index(x) for x in doc["locked"])
    if "targets" in doc:
        targets = tuple(coordinates.index(x) for x in doc["targets"])
    else:  # records written before "targets": the unlocked coordinates with a goal
        goal = doc["goal"]
        targets = tuple(
            k for k in range(len(coordinates)) if k not in locked and goal[k] is not None
        )
    status = doc.get("status")
    if status is None:  # records written before per-leg status
        status = "success" if doc["converged"] else "not_converged"
    return LegPlan(
        index=i,
        stratum=doc["stratum"],
        method=doc["method"],
        evaluator=doc["evaluator"],
        active=active,
        locked=locked,
        targets=targets,
        t0=doc["t0"],
        duration=doc["duration"],
        start=_vector(doc["start"]),
        goal=_vector(doc["goal"]),
        end=_vector(doc["end"]),
        pieces=pieces,
        error=np.nan if doc["error"] is None else doc["error"],
        iterations=doc["iterations"],
        attempts=doc["attempts"],
        energy=np.nan if doc["energy"] is None else doc["energy"],
        free_coefficients=doc["free_coefficients"],
        status=Status.from_key(status),
        basis=basis,
        n_inputs=len(inputs),
        strategy=doc.get("strategy", "newton"),  # records written before "strategy"
    )


def plan_from_document(
    cls: type[SequencePlan],
    doc: dict[str, Any],
    settings: PlannerSettings | None = None,
    model: ModelRef | None = None,
) -> SequencePlan:
    """The plan a `result.json` document describes; see `SequencePlan.from_dict`."""
    coordinates, inputs = list(doc["coordinates"]), list(doc["inputs"])
    legs = tuple(_leg_from(leg, i, coordinates, inputs) for i, leg in enumerate(doc["legs"]))
    base = settings or PlannerSettings()
    settings = dataclasses.replace(
        base,
        continuity=doc["continuity"],
        soft_start=doc["soft_start"],
        full_stop=doc["full_stop"],
        tolerance=doc["tolerance"],
        seed=doc["seed"],
        objective=doc.get("objective", base.objective),
        basis=legs[0].basis if legs else base.basis,
    )
    opt = doc.get("optimisation")
    optimisation = None
    if opt is not None:
        starts = tuple(
            StartOutcome(**{a: s[k] for k, a in _START_KEYS.items()})
            for s in ({"feasible": s["converged"], **s} for s in opt["starts"])
        )
        optimisation = Optimisation(
            starts,
            opt["best"],
            opt["newton_energy"],
            opt["method"],
            opt.get("search", ""),  # (records before these two keys)
            opt.get("no_loop_start", ""),
        )
    switches = tuple(
        Switch(
            sw["time"],
            sw["after_leg"],
            _vector([sw["jump"][u] for u in inputs]),
            _vector([sw["jump_derivative"][u] for u in inputs]),
        )
        for sw in doc["switches"]
    )
    return cls(
        scenario=doc["scenario"],
        model=model or ModelRef(doc["model"]),
        coordinates=tuple(coordinates),
        inputs=tuple(inputs),
        settings=settings,
        start=_vector(doc["start"]),
        goal=_vector(doc["goal"]),
        legs=legs,
        switches=switches,
        planned_legs=doc.get("planned_legs", len(legs)),
        message=doc["message"],
        optimisation=optimisation,
        time_scale=doc.get("time_scale", 1.0),
        notes=tuple(doc.get("notes") or ()),
        reference_energy=doc.get("reference_energy"),
        constraints=ConstraintReport.from_dict(c) if (c := doc.get("constraints")) else None,
    )
