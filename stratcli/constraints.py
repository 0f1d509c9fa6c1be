"""Limits of real hardware: the [constraints] table, rate limits met by time scaling, margins.

A scenario's optional `[constraints]` table (`ConstraintsSpec`) gives joint limits (rad),
rate and acceleration limits of the inputs (rad/s, rad/s²), self-collision with a clearance,
and obstacles (circles and boxes in the inertial frame, planar manipulators only). The
collision geometry is the physical robot the model carries: the base rectangle and the links
as capsules of radius `link_radius` (default 0.05 in the model's length unit); a link is
not checked against its neighbour in the arm, nor the first link of an arm against the base
it is mounted on.

What is done with them. Rate and acceleration limits are met exactly by time scaling (a
driftless system run s times slower has controls s times smaller and their derivatives s²
times smaller, `time_scaling.rate_limited`; `limit_timing.enforce`); the plan notes which
limit set its duration.
Every limit is then verified on a dense re-integration (`verify`: at least 2000 samples per
leg), and a plan that violates one is failed (`Status.CONSTRAINT_VIOLATED`), its message
naming the limit, the leg and the time (a URDF's own joint limits as such, with the advice
of `urdf_limits.violation_advice`). Joint limits, self-collision and obstacles are kept by
the search itself (`planners.constrained`, from `objectives.plan_sequence`); a plan it could
not move inside them is reported here with the leg where that search stalled.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, Field, Strict

from .body_clearances import check_configuration, clearances, closest_pair
from .clearance import box_corners
from .constraint_report import ConstraintReport, LegMargins
from .errors import InputError, Problem
from .frozen_json import frozen
from .limit_units import angle_coordinates
from .models.numbers import parse_length, parse_number
from .models.specs import STRICT
from .per_input import per_input
from .results import frozen_array
from .simulate import sample
from .time_scaling import rate_limited
from .urdf_limits import URDF_LIMIT
from .values import ByValue
from .wording import counted

__all__ = [
    "KEPT_FREE",
    "MARGIN_KINDS",
    "VERIFY_SAMPLES",
    "Constraints",
    "ConstraintsSpec",
    "check_configuration",
    "margin_kinds",
    "rate_limited",
    "resolve",
    "resolved_constraints",
    "rooms",
    "verify",
]

VERIFY_SAMPLES = 2000  # per leg, for the margins
KEPT_FREE = "kept instead: the plan found without the limits"  # a stalled plan's message
VIOLATION_TOL = 1e-9  # a margin below -this is a violation (rounding of the geometry)
MAX_OBSTACLES = 100
Number = Annotated[float, BeforeValidator(parse_number)]  # an angle: "60deg", "1.2 rad" too
Positive = Annotated[float, BeforeValidator(parse_number), Field(gt=0, le=1e6)]  # rad/s, rad/s²
PositiveLength = Annotated[float, BeforeValidator(parse_length), Field(gt=0, le=1e6)]
NonNegativeLength = Annotated[float, BeforeValidator(parse_length), Field(ge=0, le=1e6)]
Coordinate = Annotated[float, BeforeValidator(parse_length), Field(ge=-1e6, le=1e6)]
Point = Annotated[list[Coordinate], Field(min_length=2, max_length=2)]


class _Strict(BaseModel):
    model_config = STRICT


class CircleSpec(_Strict):
    shape: Literal["circle"]
    centre: Point
    radius: PositiveLength


class BoxSpec(_Strict):
    shape: Literal["box"]
    centre: Point
    size: Annotated[list[PositiveLength], Field(min_length=2, max_length=2)]
    rotation: Annotated[Number, Field(ge=-1e3, le=1e3)] = 0.0  # rad


Limits = Annotated[list[Number], Field(min_length=2, max_length=2)]


class ConstraintsSpec(_Strict):
    """The [constraints] table (all optional)."""

    joint_limits: Limits | list[Limits] | dict[str, Limits] | None = None
    max_rate: Positive | list[Positive] | dict[str, Positive] | None = None
    max_acceleration: Positive | list[Positive] | dict[str, Positive] | None = None
    self_collision: Annotated[bool, Strict()] = False
    clearance: NonNegativeLength = 0.0
    link_radius: PositiveLength = 0.05
    obstacles: list[Annotated[CircleSpec | BoxSpec, Field(discriminator="shape")]] = Field(
        default_factory=list, max_length=MAX_OBSTACLES
    )


@dataclass(frozen=True, eq=False)
class Constraints(ByValue):
    """Resolved against a model: per-coordinate limits, per-input rates, geometry. A value:
    equal by its fields' values (arrays element by element), its arrays and table read-only."""

    lower: np.ndarray  # (n,) -inf where a coordinate has no limit
    upper: np.ndarray
    max_rate: np.ndarray | None  # (m,) per input
    max_acceleration: np.ndarray | None
    self_collision: bool
    clearance: float
    link_radius: float
    circles: tuple[tuple[np.ndarray, float], ...]  # (centre, radius)
    boxes: tuple[np.ndarray, ...]  # corners (4, 2)
    spec: dict[str, Any]  # the table as given (for result.json)
    from_urdf: tuple[int, ...] = ()  # coordinates whose limits are the URDF's (not the table's)

    def __post_init__(self) -> None:
        for name in ("lower", "upper", "max_rate", "max_acceleration"):  # (rates may be None)
            value = getattr(self, name)
            object.__setattr__(self, name, None if value is None else frozen_array(value))
        circles = tuple((frozen_array(centre), r) for centre, r in self.circles)
        object.__setattr__(self, "circles", circles)
        object.__setattr__(self, "boxes", tuple(frozen_array(b) for b in self.boxes))
        object.__setattr__(self, "spec", frozen(self.spec))

    @property
    def geometric(self) -> bool:
        return self.self_collision or bool(self.circles or self.boxes)

    @property
    def timed(self) -> bool:
        """Rate or acceleration limits: they slow a plan by a factor of its own."""
        return self.max_rate is not None or self.max_acceleration is not None


def resolve(spec: ConstraintsSpec, system) -> Constraints:
    """Check the table against the model and resolve it per coordinate and input.

    Raises
    ------
    InputError
        One problem per bad entry, each naming its field.
    """
    problems: list[Problem] = []
    n = system.n
    robot = getattr(system, "robot", None)
    spatial = getattr(system, "spatial", None)  # a URDF robot: its joints come first
    joints = robot.n_joints if robot is not None else n  # limits apply to the joints
    lower, upper = np.full(n, -np.inf), np.full(n, np.inf)
    if spatial is not None:  # the URDF's limits, unless the table overrides them
        joints = len(spatial.joint_names)
        lower[:joints], upper[:joints] = spatial.lower, spatial.upper
    limits = spec.joint_limits
    if isinstance(limits, list) and not limits:  # (an empty list of pairs passes the schema)
        problems.append(
            Problem(
                "constraints.joint_limits",
                "empty: give [lower, upper] for every joint, one pair per joint, or a table "
                f"by name ({system.states[0]} = [lower, upper])",
            )
        )
        limits = None
    if isinstance(limits, dict):
        pairs = {}
        for name, pair in limits.items():
            if name not in system.states:
                problems.append(
                    Problem(
                        f"constraints.joint_limits.{name}",
                        f"not a coordinate ({', '.join(system.states)})",
                    )
                )
            elif spatial is not None and system.states.index(name) >= joints:
                problems.append(  # (its search keeps the joints within limits, not R)
                    Problem(
                        f"constraints.joint_limits.{name}",
                        "a component of the base's attitude (a rotation vector), not a joint: "
                        "a URDF robot's limits are on its joints "
                        f"({', '.join(system.states[:joints])}); the attitude is a goal",
                    )
                )
            else:
                pairs[system.states.index(name)] = pair
    elif limits is not None and limits and isinstance(limits[0], list):
        if len(limits) != joints:
            problems.append(
                Problem(
                    "constraints.joint_limits", f"give {joints} [lower, upper] pairs, one per joint"
                )
            )
        pairs = dict(enumerate(limits[:joints]))
    elif limits is not None:
        pairs = dict.fromkeys(range(joints), limits)
    else:
        pairs = {}
    # one line per field as the user wrote it: by name, by index, or once for every joint
    if isinstance(limits, dict):
        named = {i: f"constraints.joint_limits.{system.states[i]}" for i in pairs}
    elif limits and isinstance(limits[0], list):
        named = {i: f"constraints.joint_limits[{i}]" for i in pairs}
    else:
        named = dict.fromkeys(pairs, "constraints.joint_limits")
    fields = set()
    for i, (lo, hi) in pairs.items():
        field = named[i]
        if not lo < hi and field not in fields:
            fields.add(field)
            problems.append(Problem(field, f"lower {lo:g} must be below upper {hi:g}"))
        lower[i], upper[i] = lo, hi
    rate = per_input(spec.max_rate, system, "constraints.max_rate", problems)
    acc = per_input(spec.max_acceleration, system, "constraints.max_acceleration", problems)
    if not (spec.self_collision or spec.obstacles):  # the sizes of bodies nothing measures
        message = "applies to self_collision = true and to obstacles, and neither is set"
        if spec.clearance > 0:
            problems.append(Problem("constraints.clearance", message))
        # a radius other than the default (resolved.json writes the default out)
        if spec.link_radius != ConstraintsSpec.model_fields["link_radius"].default:
            problems.append(Problem("constraints.link_radius", message))
    geometric = (
        ("self_collision", spec.self_collision, "needs"),
        ("obstacles", spec.obstacles, "need"),
    )
    for key, asked, verb in geometric:
        if asked and robot is None:  # the key a user wrote, by name
            problems.append(
                Problem(
                    f"constraints.{key}",
                    f"{key} {verb} a planar robot (a preset or a planar manipulator); for custom "
                    "and URDF models only joint, rate and acceleration limits are supported",
                )
            )
    if problems:
        raise InputError(problems)
    circles = tuple(
        (np.asarray(o.centre, float), o.radius) for o in spec.obstacles if o.shape == "circle"
    )
    boxes = tuple(
        box_corners(o.centre, o.size, o.rotation) for o in spec.obstacles if o.shape == "box"
    )
    from_urdf = tuple(i for i in range(joints) if spatial is not None and i not in pairs)
    return Constraints(
        lower, upper, rate, acc, spec.self_collision, spec.clearance, spec.link_radius,
        circles, boxes, spec.model_dump(mode="json"), from_urdf,
    )  # fmt: skip


def resolved_constraints(plan) -> Constraints:
    """A plan's [constraints] table (`plan.constraints.spec`, as result.json records it)
    resolved on its model again (limits per coordinate)."""
    return resolve(ConstraintsSpec.model_validate(plan.constraints.spec), plan.system)


# --------------------------------------------------------------------------------------------
# Margins on a dense re-integration
# --------------------------------------------------------------------------------------------


def _first(values: np.ndarray, t: np.ndarray) -> tuple[float, float]:
    k = int(np.argmin(values))
    return float(values[k]), float(t[k])


MARGIN_KINDS = ("joint_limit", "rate", "acceleration", "self_clearance", "obstacle_clearance")


def margin_kinds(system, c: Constraints) -> tuple[str, ...]:
    """The margins `c` asks for on `system`, in `MARGIN_KINDS`' order (result.json's names;
    clearances only where the model carries a robot's geometry)."""
    geometric = c.geometric and getattr(system, "robot", None) is not None
    asked = {
        "joint_limit": bool((np.isfinite(c.lower) | np.isfinite(c.upper)).any()),
        "rate": c.max_rate is not None,
        "acceleration": c.max_acceleration is not None,
        "self_clearance": geometric and c.self_collision,
        "obstacle_clearance": geometric and bool(c.circles or c.boxes),
    }
    return tuple(k for k in MARGIN_KINDS if asked[k])


def rooms(system, c: Constraints, q, u, du) -> dict[str, np.ndarray]:
    """The room left to each limit at every sample: (N, columns) arrays by result.json's
    margin name ("joint_limit": per limited coordinate, "rate" and "acceleration": per input,
    "self_clearance" and "obstacle_clearance": the smallest clearance, one column), present
    where the constraints ask for them; negative where a limit is broken.

    Parameters
    ----------
    system : System
        The model (its `robot` carries the collision geometry).
    c : Constraints
        The resolved [constraints] table.
    q, u, du : numpy.ndarray
        (N, n) configurations, (N, m) controls and their derivatives, sample by sample.
    """
    kinds = margin_kinds(system, c)
    found: dict[str, np.ndarray] = {}
    if "joint_limit" in kinds:
        limited = np.isfinite(c.lower) | np.isfinite(c.upper)
        found["joint_limit"] = np.minimum(q - c.lower, c.upper - q)[:, limited]
    if "rate" in kinds:
        found["rate"] = c.max_rate - np.abs(u)
    if "acceleration" in kinds:
        found["acceleration"] = c.max_acceleration - np.abs(du)
    if "self_clearance" in kinds or "obstacle_clearance" in kinds:
        own, world = clearances(system.robot, q, c)
        found.update(self_clearance=own[:, None], obstacle_clearance=world[:, None])
    return {k: found[k] for k in kinds}


def verify(
    plan, c: Constraints, samples: int = VERIFY_SAMPLES, also: tuple[str, ...] = ()
) -> ConstraintReport:
    """Smallest margins per leg on an independent re-integration (`samples` per leg) and the
    first violation, named by limit, leg and time; `also`: limits of the whole plan broken
    besides (its duration's budget), counted among the others where one of these is."""
    trajectory = sample(plan, samples)
    robot = getattr(plan.system, "robot", None)
    margins, violated, violation = [], "", None
    others: list[str] = []  # the violations after the first
    limited = np.flatnonzero(np.isfinite(c.lower) | np.isfinite(c.upper))
    units = {"rate": "rad/s", "acceleration": "rad/s²"}
    for leg in plan.legs:
        sel = trajectory.leg == leg.index
        t, q = trajectory.t[sel], trajectory.q[sel]
        room = rooms(plan.system, c, q, trajectory.u[sel], trajectory.du[sel])
        found: dict[str, tuple[float, float, str]] = {}
        for key, values in room.items():
            k = int(np.unravel_index(np.argmin(values), values.shape)[1])
            value, when = _first(values[:, k], t)
            if key == "joint_limit":
                j = int(limited[k])
                name = plan.coordinates[j]
                urdf = f"{URDF_LIMIT} {name} [{c.lower[j]:.3g}, {c.upper[j]:.3g}]"
                what = urdf if j in c.from_urdf else f"the joint limits of {name}"
            elif key in units:
                limit = c.max_rate if key == "rate" else c.max_acceleration
                what = f"the {key} limit of {plan.inputs[k]} ({limit[k]:g} {units[key]})"
            else:
                obstacles = key == "obstacle_clearance"
                what = "an obstacle" if obstacles else "self-collision"
                if value < -VIOLATION_TOL:  # which bodies (and obstacle)
                    index = int(np.argmin(values[:, 0]))
                    pair, _ = closest_pair(robot, q[index], c, obstacles=obstacles)
                    what = f"{what} ({pair})"
            found[key] = (value, when, what)
        margins.append(LegMargins(**{k: v[0] for k, v in found.items()}))
        for key, (value, when, what) in found.items():
            if value >= -VIOLATION_TOL:
                continue
            if violated:  # the first is named; the others counted (a worse one came later)
                others.append(f"leg {leg.index + 1}'s {WORDS[key]}")
                continue
            unit = UNITS.get(key, "")  # clearances: in the model's own length unit
            if key == "joint_limit" and not angle_coordinates(plan.system):
                unit = ""  # a custom model's coordinates: its own units
            violated = (
                f"leg {leg.index + 1} ({leg.stratum}) violates {what} by "
                f"{-value:.3g}{unit} at t = {when:.3f} s"
            )
            violation = {"leg": leg.index + 1, "limit": key, "what": what}
            violation.update(by=-value, t=when)
    others += list(also) if violated else []
    if others:
        violated += f" (and {counted(len(others), 'more limit')}: {', '.join(others)})"
    return ConstraintReport(
        c.spec, tuple(margins), samples, violated, violation=violation,
        joint_limits=_joint_limits(plan.coordinates, c),
    )  # fmt: skip


def _joint_limits(names, c: Constraints) -> dict[str, dict]:
    """The limits verified, by coordinate (`ConstraintReport.joint_limits`): a URDF robot's
    come from its file unless the table overrides them, and result.json should say which."""
    bound = lambda x: float(x) if np.isfinite(x) else None  # noqa: E731
    return {
        name: {
            "lower": bound(c.lower[j]),
            "upper": bound(c.upper[j]),
            "from": "urdf" if j in c.from_urdf else "table",
        }
        for j, name in enumerate(names)
        if np.isfinite(c.lower[j]) or np.isfinite(c.upper[j])
    }


UNITS = {"joint_limit": " rad", "rate": " rad/s", "acceleration": " rad/s²"}  # of a violation
WORDS = {  # a violation after the first, in the message's count of them
    "joint_limit": "joint limits", "rate": "rate limit", "acceleration": "acceleration limit",
    "self_clearance": "self-collision", "obstacle_clearance": "obstacles",
}  # fmt: skip
