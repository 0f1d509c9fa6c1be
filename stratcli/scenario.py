"""Scenario files: TOML validated with pydantic, resolved into a planning task (DESIGN §8).

Every problem is reported as one line `file: field.path: message (got value)`; nothing is
evaluated as code (angles such as "pi/3" or "60deg" go through the safe expression parser).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import sympy as sp
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    Strict,
    ValidationError,
    model_validator,
)

from . import tomlwrite
from .controls import MAX_PERIODS_PER_LEG
from .errors import InputError, Problem
from .models.expressions import ExpressionError, parse_expression, parse_number
from .models.manipulator import ManipulatorSystem
from .models.planar import Arm, Base, Link, PlanarManipulator
from .models.presets import PRESETS, preset
from .models.system import Stratum, System
from .settings import (
    MAX_DURATION,
    MIN_DURATION,
    UNKNOWN_KEY_ERRORS,
    DecomposeSettings,
    LieSettings,
    PlannerSettings,
)
from .stratified import LegSpec, check_legs
from .tomlread import parse_toml, read_scenario_text, reject_non_finite

MAX_COORDINATE = 1e4  # |q_i| of a start, goal or via (rad, or the model's length unit)

Number = Annotated[float, BeforeValidator(parse_number)]
Coordinate = Annotated[float, Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]


def _parse_target(value: Any) -> float | None:
    """A goal entry: a number, or "*" (None) for a coordinate whose end value is free."""
    return None if isinstance(value, str) and value.strip() == "*" else parse_number(value)


Target = Annotated[Coordinate | None, BeforeValidator(_parse_target)]
Name = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=64)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class PresetModel(_Strict):
    """One of the paper's models, exactly as printed."""

    kind: Literal["preset"]
    name: Literal["one-arm", "two-arm"]


class CustomStratum(_Strict):
    name: Name
    active: list[Name] = Field(min_length=1)
    locked: list[Name] = []
    parameters: dict[str, Number] = {}


class CustomModel(_Strict):
    """A driftless system from expressions: one vector field per input (DESIGN §7)."""

    kind: Literal["custom"]
    states: list[Name] = Field(min_length=1)
    inputs: list[Name] = Field(min_length=1)
    parameters: dict[Name, Number] = {}
    fields: dict[str, list[str | float]]
    strata: list[CustomStratum] = Field(min_length=1)


# Physical ranges of planar-manipulator parameters (SI units). They bound every quantity so
# that no product in the model overflows and no ratio underflows; real space robots sit well
# inside them. At most MAX_LINKS links in total (the default strata grow as k²).
MASS = {"ge": 1e-6, "le": 1e6}  # kg
LENGTH = {"ge": 1e-6, "le": 1e3}  # m
INERTIA = {"ge": 0, "le": 1e9}  # kg m²
MOUNT = {"ge": -1e3, "le": 1e3}  # m, base frame
MAX_LINKS = 24
MAX_ARMS = 8

Coordinate = Annotated[Number, Field(**MOUNT)]


class LinkSpec(_Strict):
    mass: float = Field(**MASS, description="kg, in [1e-6, 1e6]")
    length: float = Field(**LENGTH, description="m, in [1e-6, 1e3]")
    com: float | None = Field(None, ge=0, le=1e3, description="CM offset from the proximal joint")
    inertia: float | None = Field(
        None, **INERTIA, description="about the link's CM, in [0, 1e9]; rod if omitted"
    )


class ArmSpec(_Strict):
    mount: tuple[Coordinate, Coordinate]
    zero_angle: Annotated[Number, Field(ge=-1e3, le=1e3)] = 0.0
    sense: Literal[1, -1] = 1
    links: list[LinkSpec] = Field(min_length=1, max_length=MAX_LINKS)


class BaseSpec(_Strict):
    mass: float = Field(**MASS)
    inertia: float | None = Field(None, gt=0, le=INERTIA["le"])
    a: float | None = Field(None, **LENGTH, description="rectangle width (inertia m(a²+b²)/12)")
    b: float | None = Field(None, **LENGTH, description="rectangle height")


class PlanarModel(_Strict):
    """A planar free-floating manipulator from physical parameters (MODELS.md).

    Masses in [1e-6, 1e6] kg, lengths and the base's a, b in [1e-6, 1e3] m, inertias in
    [0, 1e9] kg m² (the base's > 0), mounts within ±1e3 m, at most 8 arms and 24 links.
    """

    kind: Literal["planar-manipulator"]
    base: BaseSpec
    arms: list[ArmSpec] = Field(min_length=1, max_length=MAX_ARMS)
    strata: list[list[int]] | None = Field(
        None,
        max_length=1000,
        description="lock sets as joint numbers; default all single locks (+ pairs)",
    )

    @model_validator(mode="after")
    def _few_links(self) -> PlanarModel:
        k = sum(len(a.links) for a in self.arms)
        if k > MAX_LINKS:
            raise ValueError(f"at most {MAX_LINKS} links in total, got {k}")
        return self


ModelSpec = Annotated[PresetModel | CustomModel | PlanarModel, Field(discriminator="kind")]
KINDS = ("preset", "custom", "planar-manipulator")


class TaskSpec(_Strict):
    start: list[Annotated[Coordinate, BeforeValidator(parse_number)]] = Field(max_length=1000)
    goal: list[Target] = Field(max_length=1000)


class LegEntry(_Strict):
    stratum: str = Field(max_length=200)
    method: Literal["newton", "lie"] = "newton"
    goal: list[Target] | None = Field(None, max_length=1000)
    duration: Annotated[float, Strict(), Field(ge=MIN_DURATION, le=MAX_DURATION)] | None = None
    # method "lie": keys of [planner.lie] overridden for this leg (validated as LieSettings)
    lie: dict[str, Any] | None = None


class ReferenceSpec(_Strict):
    energy: Annotated[float, Strict()] | None = None
    source: str = Field("", max_length=1000)


class Scenario(_Strict):
    """A scenario file: what to plan (task, legs or auto mode), on which model, and how."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+$", max_length=100)]
    description: str = Field("", max_length=10_000)
    model: ModelSpec
    task: TaskSpec
    planner: PlannerSettings = PlannerSettings()
    legs: list[LegEntry] | None = Field(None, min_length=1, max_length=1000)
    decompose: DecomposeSettings | None = None
    reference: ReferenceSpec | None = None


@dataclass
class Task:
    """A validated scenario, ready to plan."""

    scenario: Scenario
    system: System
    start: np.ndarray
    goal: np.ndarray
    legs: list[LegSpec]
    settings: PlannerSettings
    source: str
    text: str

    @property
    def model_name(self) -> str:
        """Preset name, "planar-manipulator" or "custom" (the result.json `model` key)."""
        model = self.scenario.model
        return model.name if model.kind == "preset" else model.kind


def _path(loc: tuple) -> str:
    parts: list[str] = []
    for i, item in enumerate(loc):
        if isinstance(item, int):
            parts[-1] = f"{parts[-1]}[{item}]" if parts else f"[{item}]"
        elif i > 0 and loc[i - 1] == "model" and item in KINDS:
            continue  # pydantic's tag of the discriminated union, not a key of the file
        else:
            parts.append(str(item))
    return ".".join(parts)


def _fields_of(cls: Any) -> dict[str, Any] | None:
    """Field name → annotation of a schema class (pydantic model or pydantic dataclass)."""
    if isinstance(cls, type) and issubclass(cls, BaseModel):
        return {k: f.annotation for k, f in cls.model_fields.items()}
    fields = getattr(cls, "__pydantic_fields__", None)
    return None if fields is None else {k: f.annotation for k, f in fields.items()}


def _allowed_keys(loc: tuple) -> list[str]:
    """Keys allowed at the table that holds `loc[-1]`, by walking the schema."""
    cls: Any = Scenario
    for item in loc[:-1]:
        if isinstance(item, int):
            continue
        if item in KINDS and cls is None:
            cls = {"preset": PresetModel, "custom": CustomModel}.get(item, PlanarModel)
            continue
        fields = _fields_of(cls)
        if fields is None or item not in fields:
            return []
        cls = None if item == "model" else _unwrap(fields[item])
    fields = _fields_of(cls)
    return list(fields) if fields else []


def _unwrap(ann: Any) -> Any:
    if _fields_of(ann) is not None:
        return ann
    for a in getattr(ann, "__args__", None) or ():
        found = _unwrap(a)
        if found is not None:
            return found
    return None


def _problems(exc: ValidationError, prefix: tuple = ()) -> list[Problem]:
    out = []
    for err in exc.errors():
        loc = prefix + tuple(err["loc"])
        kind = err["type"]
        if kind in UNKNOWN_KEY_ERRORS:
            allowed = _allowed_keys(loc)
            hint = f" (allowed: {', '.join(allowed)})" if allowed else ""
            out.append(Problem(_path(loc), f"unknown key{hint}"))
            continue
        msg = err["msg"].removeprefix("Value error, ")
        if kind == "missing":
            msg = "required field is missing"
        shown = "" if kind == "missing" else f" (got {_short(err['input'])})"
        out.append(Problem(_path(loc), f"{msg}{shown}"))
    return out


def _short(value: Any) -> str:
    """repr of an offending value, cut to one readable line."""
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def load_scenario(source: str | Path | Mapping[str, Any], name: str | None = None) -> Task:
    """Read, validate and resolve a scenario.

    Parameters
    ----------
    source : str, Path or Mapping
        A path to a TOML file; TOML text (a string with a newline or "="); or a plain `dict`
        with the same structure as the file (so a sweep never templates TOML strings).
    name : str, optional
        How messages refer to the source (default: the path, "<text>" or "<dict>").

    Returns
    -------
    Task
        The validated scenario with its model built, start, goal and legs.

    Raises
    ------
    InputError
        Naming every problem, one line each: `source: field.path: message (got value)`.
    """
    if isinstance(source, Mapping):
        return _from_raw(dict(source), None, name or "<dict>")
    if isinstance(source, str) and ("\n" in source or "=" in source):
        return parse_scenario(source, name or "<text>")
    path = Path(source)
    where = name or str(path)
    try:
        text = read_scenario_text(path)
    except InputError as exc:
        raise exc.with_source(where) from None
    return parse_scenario(text, where)


def parse_scenario(text: str, source: str = "<scenario>") -> Task:
    """`load_scenario` for TOML text."""
    return _from_raw(parse_toml(text, source), text, source)


def _from_raw(raw: dict[str, Any], text: str | None, source: str) -> Task:
    if non_finite := reject_non_finite(raw):
        raise InputError(non_finite, source)
    try:
        scenario = Scenario.model_validate(raw)
    except ValidationError as exc:
        raise InputError(_problems(exc), source) from None
    if text is None:  # a dict: record it as the TOML file it stands for
        try:
            text = tomlwrite.dumps(raw)
        except (TypeError, ValueError) as exc:
            raise InputError(f"cannot be written as TOML: {exc}", source) from None
    try:
        return _resolve(scenario, source, text)
    except InputError as exc:
        raise exc.with_source(source) from None


def build_system(spec: PresetModel | CustomModel | PlanarModel) -> System:
    """The model named or described by the scenario's [model] table (which it keeps as
    `spec`, the reference plans carry)."""
    if spec.kind == "preset":
        system = preset(spec.name)
    elif spec.kind == "planar-manipulator":
        system = _planar_system(spec)
    else:
        system = _custom_system(spec)
    system.spec = spec
    return system


def _planar_system(spec: PlanarModel) -> System:
    b = spec.base
    problems = []
    if b.inertia is None and (b.a is None or b.b is None):
        problems.append(Problem("model.base", "give either inertia or the rectangle a and b"))
    arms = []
    for i, a in enumerate(spec.arms):
        try:
            links = tuple(Link(x.mass, x.length, x.com, x.inertia) for x in a.links)
            arms.append(Arm((a.mount[0], a.mount[1]), a.zero_angle, a.sense, links))
        except (ValueError, ArithmeticError) as exc:
            raise InputError([Problem(f"model.arms[{i}]", str(exc))]) from None
    k = sum(len(a.links) for a in arms)
    lock_sets = None
    if spec.strata is not None:
        lock_sets = []
        for i, locks in enumerate(spec.strata):
            bad = [j for j in locks if not 1 <= j <= k]
            if bad or not locks or len(set(locks)) == k:
                problems.append(
                    Problem(
                        f"model.strata[{i}]",
                        f"lock set {locks} must name 1..{k - 1} distinct joints out of 1..{k}",
                    )
                )
            lock_sets.append(tuple(sorted({j - 1 for j in locks})))
    if problems:
        raise InputError(problems)
    try:
        base = (
            Base(b.mass, b.inertia, b.a, b.b)
            if b.inertia is not None
            else Base.rectangle(b.mass, b.a, b.b)
        )
        robot = PlanarManipulator(base, tuple(arms))
        return ManipulatorSystem(
            robot,
            lock_sets=lock_sets,
            description=f"planar manipulator, {k} joints on {len(arms)} arm(s)",
        )
    except (ValueError, ArithmeticError) as exc:  # e.g. a zero total inertia
        raise InputError([Problem("model", f"not a usable robot: {exc}")]) from None


def _custom_system(spec: CustomModel) -> System:
    problems: list[Problem] = []
    states, inputs = tuple(spec.states), tuple(spec.inputs)
    for what, names in (("states", states), ("inputs", inputs)):
        dup = sorted({x for x in names if names.count(x) > 1})
        if dup:
            problems.append(Problem(f"model.{what}", f"duplicate names: {', '.join(dup)}"))
    clash = set(states) & (set(inputs) | set(spec.parameters))
    if clash:
        problems.append(Problem("model", f"names used twice: {', '.join(sorted(clash))}"))
    symbols = {s: sp.Symbol(s, real=True) for s in (*states, *spec.parameters)}
    G = sp.zeros(len(states), len(inputs))
    for name in spec.fields:
        if name not in inputs:
            problems.append(
                Problem(f"model.fields.{name}", f"not an input (inputs: {', '.join(inputs)})")
            )
    for j, u in enumerate(inputs):
        column = spec.fields.get(u)
        if column is None:
            problems.append(Problem(f"model.fields.{u}", "vector field of this input is missing"))
            continue
        if len(column) != len(states):
            problems.append(
                Problem(
                    f"model.fields.{u}",
                    f"needs {len(states)} entries (one per state), got {len(column)}",
                )
            )
            continue
        for i, entry in enumerate(column):
            try:
                G[i, j] = parse_expression(str(entry), symbols)
            except ExpressionError as exc:
                problems.append(Problem(f"model.fields.{u}[{i}]", str(exc)))
    strata: dict[str, Stratum] = {}
    for k, s in enumerate(spec.strata):
        where = f"model.strata[{k}]"
        bad = [x for x in s.active if x not in inputs]
        bad += [x for x in s.locked if x not in states]
        bad += [x for x in s.parameters if x not in spec.parameters]
        if bad:
            problems.append(Problem(where, f"unknown names: {', '.join(bad)}"))
            continue
        if s.name in strata:
            problems.append(Problem(f"{where}.name", f"duplicate stratum {s.name!r}"))
        strata[s.name] = Stratum(
            s.name,
            tuple(states.index(x) for x in s.locked),
            tuple(inputs.index(x) for x in s.active),
            tuple(sorted(s.parameters.items())),
        )
    if problems:
        raise InputError(problems)
    system = System("custom", states, inputs, G, strata, dict(spec.parameters))
    try:
        system.check()
    except InputError as exc:
        raise exc.prefixed("model") from None
    return system


def _leg_lie(entry: LegEntry, i: int, planner: PlannerSettings, problems: list[Problem]):
    """A Lie leg's settings: [planner.lie] with the leg's own `lie` keys on top."""
    if entry.method != "lie" or entry.lie is None:
        return None
    try:
        return dataclasses.replace(planner.lie, **entry.lie)
    except ValidationError as exc:
        problems.extend(_problems(exc, ("legs", i, "lie")))
    except TypeError:  # an unknown key (dataclasses.replace refuses it before pydantic)
        names = [f.name for f in dataclasses.fields(LieSettings)]
        known, unknown = ", ".join(names), ", ".join(sorted(set(entry.lie) - set(names)))
        problems.append(Problem(f"legs[{i}].lie", f"unknown key {unknown} (allowed: {known})"))
    return None


def _resolve(scenario: Scenario, source: str, text: str) -> Task:
    system = build_system(scenario.model)
    n = system.n
    problems: list[Problem] = []
    names = ", ".join(system.states)

    def vector(values: list[float] | None, where: str) -> np.ndarray | None:
        if values is not None and len(values) != n:
            problems.append(Problem(where, f"needs {n} values ({names}), got {len(values)}"))
            return None
        if values is None:
            return None
        return np.array([np.nan if v is None else v for v in values], dtype=float)

    start = vector(scenario.task.start, "task.start")
    goal = vector(scenario.task.goal, "task.goal")
    p = scenario.planner
    legs: list[LegSpec] = []
    if scenario.legs is None and scenario.decompose is None:
        problems.append(
            Problem(
                "legs",
                "give either [[legs]] (the strata in order) or a [decompose] table (auto "
                "mode: stratplan finds the sequence); the scenario has neither",
            )
        )
    for i, name in enumerate((scenario.decompose.strata or []) if scenario.decompose else []):
        if name not in system.strata:
            problems.append(
                Problem(
                    f"decompose.strata[{i}]",
                    f"unknown stratum {name!r} (this model has: {', '.join(system.strata)})",
                )
            )
    for i, entry in enumerate(scenario.legs or []):
        where = f"legs[{i}]"
        if entry.stratum not in system.strata:
            problems.append(
                Problem(
                    f"{where}.stratum",
                    f"unknown stratum {entry.stratum!r} (this model has: "
                    f"{', '.join(system.strata)})",
                )
            )
        last = i == len(scenario.legs) - 1
        leg_goal = vector(entry.goal, f"{where}.goal")
        if leg_goal is None and entry.goal is None:
            if not last:
                problems.append(
                    Problem(
                        f"{where}.goal",
                        "a via configuration is required (only the last "
                        "leg may omit its goal, which is then task.goal)",
                    )
                )
            leg_goal = goal
        elif last and goal is not None and leg_goal is not None:
            if not np.allclose(leg_goal, goal, rtol=0.0, atol=1e-12, equal_nan=True):
                problems.append(
                    Problem(
                        f"{where}.goal",
                        "the last leg's goal differs from task.goal; omit it or make them equal",
                    )
                )
        if leg_goal is not None:
            legs.append(
                LegSpec(
                    stratum=entry.stratum,
                    goal=leg_goal,
                    method=entry.method,
                    duration=entry.duration or p.leg_duration,
                    lie=_leg_lie(entry, i, p, problems),
                )
            )
            duration = (
                (legs[-1].lie or p.lie).step_duration
                if entry.method == "lie"
                else (legs[-1].duration)
            )
            if duration / p.basis.period > MAX_PERIODS_PER_LEG:
                problems.append(
                    Problem(
                        f"{where}.duration" if entry.duration else "planner.basis.period",
                        f"a leg of {duration:g} s spans {duration / p.basis.period:.3g} basis "
                        f"periods (at most {MAX_PERIODS_PER_LEG}); use a longer period or "
                        "a shorter leg",
                    )
                )
        if entry.method == "lie" and entry.duration is not None:
            problems.append(
                Problem(
                    f"{where}.duration",
                    "a Lie leg lasts (number of steps) x lie.step_duration; set "
                    "lie = { step_duration = ... } instead",
                )
            )
        if entry.method != "lie" and entry.lie is not None:
            problems.append(Problem(f"{where}.lie", 'only legs with method = "lie" take it'))
    if problems:
        raise InputError(problems)
    settings = p
    if p.evaluator == "quadrature":
        for leg in legs:
            if not system.compiled(leg.stratum).supports_quadrature:
                problems.append(
                    Problem(
                        "planner.evaluator",
                        f"stratum {leg.stratum} does not allow the "
                        "quadrature path (a non-constant row depends on a non-explicit "
                        "coordinate); use 'auto' or 'ode'",
                    )
                )
    if problems:
        raise InputError(problems)

    check_legs(system, start, legs, settings)
    return Task(scenario, system, start, goal, legs, settings, source, text)


__all__ = ["PRESETS", "Scenario", "Task", "build_system", "load_scenario", "parse_scenario"]
