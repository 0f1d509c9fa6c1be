"""The `[model]` table of a scenario, and the model it describes.

`PresetModel` (the paper's printed models), `CustomModel` (vector fields from expressions,
parsed safely) and `PlanarModel` (a planar free-floating manipulator from physical
parameters) are validated here and built by `build_system`. A plan refers to its model by
this table (`results.ModelRef`); `system_from_ref` rebuilds it, once per process, e.g. for a
plan loaded from a record or unpickled in another process.
"""

from __future__ import annotations

import keyword
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    Strict,
    TypeAdapter,
    ValidationError,
    model_validator,
)

from ..errors import InputError, Problem
from .manipulator import ManipulatorSystem
from .numbers import ExpressionError, parse_length, parse_number
from .planar import Arm, Base, Link, PlanarManipulator
from .presets import PRESETS, preset
from .system import Stratum, System

__all__ = [
    "KINDS",
    "STRICT",
    "CustomModel",
    "ModelSpec",
    "Number",
    "PlanarModel",
    "PresetModel",
    "UrdfModel",
    "build_system",
    "model_states",
    "system_from_ref",
]

Number = Annotated[float, BeforeValidator(parse_number)]  # also "pi/3", "60deg"
StrictWhole = Annotated[int, Strict()]


def _field_entry(value: Any) -> Any:
    """An expression or a number, in one message where it is neither: `true` was read as
    1.0, and a list was refused twice ("model.fields.w[2].str: ...", then ".float: ...")."""
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        shown = str(value).lower() if isinstance(value, bool) else repr(value)
        raise ValueError(f"must be an expression (a string) or a number (got {shown})")
    return value


FieldEntry = Annotated[str | float, BeforeValidator(_field_entry)]
Name = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=64)]


STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


class _Strict(BaseModel):
    model_config = STRICT


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
    """A driftless system from expressions: one vector field per input."""

    kind: Literal["custom"]
    states: list[Name] = Field(min_length=1)
    inputs: list[Name] = Field(min_length=1)
    parameters: dict[Name, Number] = {}
    fields: dict[str, list[FieldEntry]]
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

MountCoordinate = Annotated[float, BeforeValidator(parse_length), Field(**MOUNT)]  # no unit


class LinkSpec(_Strict):
    mass: float = Field(**MASS, strict=True, description="kg, in [1e-6, 1e6]")
    length: float = Field(**LENGTH, strict=True, description="m, in [1e-6, 1e3]")
    com: float | None = Field(
        None, ge=0, le=1e3, strict=True, description="CM offset from the proximal joint"
    )
    inertia: float | None = Field(
        None, **INERTIA, strict=True, description="about the link's CM, in [0, 1e9]; rod if omitted"
    )


class ArmSpec(_Strict):
    mount: tuple[MountCoordinate, MountCoordinate]
    zero_angle: Annotated[Number, Field(ge=-1e3, le=1e3)] = 0.0
    sense: Literal[1, -1] = 1
    links: list[LinkSpec] = Field(min_length=1, max_length=MAX_LINKS)


class BaseSpec(_Strict):
    mass: float = Field(**MASS, strict=True)
    inertia: float | None = Field(None, gt=0, le=INERTIA["le"], strict=True)
    a: float | None = Field(
        None, **LENGTH, strict=True, description="rectangle width (inertia m(a²+b²)/12)"
    )
    b: float | None = Field(None, **LENGTH, strict=True, description="rectangle height")


class PlanarModel(_Strict):
    """A planar free-floating manipulator from physical parameters (docs/planar_model.md).

    Masses in [1e-6, 1e6] kg, lengths and the base's a, b in [1e-6, 1e3] m, inertias in
    [0, 1e9] kg m² (the base's > 0), mounts within ±1e3 m, at most 8 arms and 24 links.
    """

    kind: Literal["planar-manipulator"]
    base: BaseSpec
    arms: list[ArmSpec] = Field(min_length=1, max_length=MAX_ARMS)
    strata: list[list[StrictWhole]] | None = Field(  # (["1"] was read as joint 1)
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


class UrdfModel(_Strict):
    """A spatial free-floating manipulator from a URDF (needs `stratplan[spatial]`).

    `path` is relative to the scenario file (made absolute when the scenario is read); `base`
    is the free-flying link (the URDF's root); `strata` are lock sets of joint names (default:
    every single lock, plus every pair from four joints on).
    """

    kind: Literal["urdf"]
    path: str = Field(min_length=1, max_length=4096)
    base: str | None = Field(None, max_length=200)
    strata: list[list[str]] | None = Field(None, max_length=1000)


ModelSpec = Annotated[
    PresetModel | CustomModel | PlanarModel | UrdfModel, Field(discriminator="kind")
]
KINDS = ("preset", "custom", "planar-manipulator", "urdf")

_SPEC: TypeAdapter[Any] = TypeAdapter(ModelSpec)


def _bad_lock_set(locks: list[int], bad: list[int], k: int) -> str:
    """Why a planar manipulator's lock set is refused, in the terms of the robot's joints:
    "must name 1..1 distinct joints out of 1..2" did not say that joint 3 does not exist."""
    joints = f"this robot's joints are 1..{k}, numbered arm by arm"
    if bad:
        return f"lock set {locks}: no joint {', '.join(map(str, bad))} ({joints})"
    if len(set(locks)) < len(locks):
        return f"lock set {locks} names a joint twice"
    if not locks:
        return "an empty lock set: a stratum locks 1 joint or more"
    return f"lock set {locks} locks every joint: a stratum leaves one free at least ({joints})"


def build_system(spec: PresetModel | CustomModel | PlanarModel | UrdfModel) -> System:
    """The model named or described by the scenario's [model] table (which it keeps as
    `spec`, the reference plans carry)."""
    if spec.kind == "preset":
        system = preset(spec.name)
    elif spec.kind == "planar-manipulator":
        system = _planar_system(spec)
    elif spec.kind == "urdf":
        from .spatial import load_spatial  # Pinocchio is imported only for URDF models

        system = load_spatial(spec.path, spec.base, spec.strata)
    else:
        system = _custom_system(spec)
    system.spec = spec
    return system


def model_states(model: Any, base_dir: Path | None = None) -> tuple[str, ...] | None:
    """The coordinates of the model a [model] table (a dict, as read) describes, or None where
    it does not build (loading the scenario names its problems). A URDF `path` is relative to
    `base_dir` (default: the working directory), as when the scenario loads."""
    urdf = isinstance(model, dict) and model.get("kind") == "urdf"
    if urdf and isinstance(model.get("path"), str):
        path = Path(model["path"]).expanduser()
        model = {**model, "path": str((base_dir or Path.cwd()) / path)}
    try:
        return tuple(build_system(_SPEC.validate_python(model)).states)
    except (ValidationError, ValueError, TypeError, OSError):  # InputError too
        return None


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
            bad = [j for j in locks if not 1 <= j <= k]  # [2, 2] was S2, without a word
            if bad or not locks or len(set(locks)) >= k or len(set(locks)) < len(locks):
                problems.append(Problem(f"model.strata[{i}]", _bad_lock_set(locks, bad, k)))
                continue
            locked = tuple(sorted({j - 1 for j in locks}))
            if locked in lock_sets:  # else one stratum fewer than given (as URDF robots')
                why = f"lock set {locks} repeats model.strata[{lock_sets.index(locked)}]"
                problems.append(Problem(f"model.strata[{i}]", why))
            lock_sets.append(locked)
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
    import sympy as sp  # only for models written as expressions (presets need none)

    from .expressions import CONSTANTS, FUNCTIONS, parse_expression

    problems: list[Problem] = []
    states, inputs = tuple(spec.states), tuple(spec.inputs)
    for what, names in (("states", states), ("inputs", inputs)):
        dup = sorted({x for x in names if names.count(x) > 1})
        if dup:
            problems.append(Problem(f"model.{what}", f"duplicate names: {', '.join(dup)}"))
    clash = set(states) & (set(inputs) | set(spec.parameters))
    if clash:
        problems.append(Problem("model", f"names used twice: {', '.join(sorted(clash))}"))
    for what, names in (("states", states), ("parameters", tuple(spec.parameters))):
        # "lambda" failed every expression as "invalid syntax"; "pi" hid the constant
        taken = [x for x in names if keyword.iskeyword(x) or x in CONSTANTS or x in FUNCTIONS]
        if taken:
            problems.append(
                Problem(
                    f"model.{what}",
                    f"{', '.join(taken)}: reserved in expressions (Python words, pi, E and the "
                    "functions): choose other names",
                )
            )
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
        for what, names in (("active", s.active), ("locked", s.locked)):
            if twice := sorted({x for x in names if names.count(x) > 1}):
                problems.append(Problem(f"{where}.{what}", f"names twice: {', '.join(twice)}"))
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
    if undefined := _undefined_fields(system, spec):
        raise InputError(undefined)
    try:
        system.check()
    except InputError as exc:
        raise exc.prefixed("model") from None
    return system


def _undefined_fields(system: System, spec: CustomModel) -> list[Problem]:
    """Field entries infinite, undefined or complex once a stratum's parameters are in
    ("tan(phi)/L" with L = 0 is sympy's ComplexInfinity, which no compiled function
    evaluates: every command ended on a traceback)."""
    import sympy as sp

    found: dict[tuple[int, int], Problem] = {}
    for stratum in system.strata.values():
        fields = system.fields_on(stratum)
        values = {**spec.parameters, **dict(stratum.parameters)}
        for c, j in enumerate(stratum.active):
            for i in range(system.n):
                entry = fields[i, c]
                bad = entry.has(sp.zoo, sp.oo, -sp.oo, sp.nan, sp.I)
                if not bad or (i, j) in found:
                    continue
                given = system.fields[i, j]
                names = sorted(str(x) for x in given.free_symbols if str(x) in values)
                with_ = ", ".join(f"{x} = {values[x]:g}" for x in names)
                complex_ = entry.has(sp.I)
                what = "complex-valued (a field is real)" if complex_ else "infinite or undefined"
                text = spec.fields[system.inputs[j]][i]
                on = f" (stratum {stratum.name!r}'s parameters)" if stratum.parameters else ""
                found[(i, j)] = Problem(
                    f"model.fields.{system.inputs[j]}[{i}]",
                    f"in {str(text)!r}: {what}" + (f" with {with_}{on}" if with_ else ""),
                )
    return [found[k] for k in sorted(found, key=lambda ij: (ij[1], ij[0]))]


@lru_cache(maxsize=16)
def _from_json(kind: str, text: str) -> System:
    return build_system(_SPEC.validate_json(text))


def system_from_ref(ref) -> System:
    """The model a `ModelRef` names, built once per process.

    Raises
    ------
    ValueError
        When the plan's model was made in Python (no `[model]` table to rebuild it from):
        bind it with `plan.with_system(system)`.
    """
    spec = ref.spec
    if spec is not None:
        return _from_json(spec.kind, spec.model_dump_json())
    if ref.name in PRESETS:
        return preset(ref.name)
    raise ValueError(
        f"the plan's model {ref.name!r} was made in Python and cannot be rebuilt; "
        "use plan.with_system(system)"
    )
