"""Scenario files: TOML validated with pydantic, resolved into a planning task.

Every problem is reported as one line `file: field.path: message (got value)`; nothing is
evaluated as code (angles such as "pi/3" or "60deg" go through the safe expression parser).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import (
    BaseModel,
    BeforeValidator,
    Field,
    Strict,
    ValidationError,
)

from . import tomlwrite
from .constraints import ConstraintsSpec, check_configuration, resolve
from .endpoint import evaluator_problems
from .errors import InputError, Problem
from .leg_checks import check_legs, pinned_vias
from .models.numbers import parse_number
from .models.presets import PRESETS
from .models.specs import (
    STRICT,
    ModelSpec,
    build_system,
)
from .models.system import System
from .planners import PLANNERS
from .planners.plugins import PLUGINS, load_plugins
from .results import none_to_nan
from .scenario_checks import (
    acceleration_problems,
    attitude_problems,
    cushion_problems,
    duration_problems,
    lie_problems,
    lie_step_problems,
    periodic_problems,
)
from .scenario_hints import beside_refused, hinted
from .scenario_legs import leg_specs, mode_problems
from .schema_problems import validation_problems
from .settings import (
    MAX_DURATION,
    MIN_DURATION,
    DecomposeSettings,
    PlannerSettings,
)
from .task import Task
from .tomlread import parse_toml, raise_non_finite, read_source, reject_non_finite

MAX_COORDINATE = 1e4  # |q_i| of a start, goal or via (rad, or the model's length unit)

Number = Annotated[float, BeforeValidator(parse_number)]
Coordinate = Annotated[float, Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]


def _parse_target(value: Any) -> float | None:
    """A goal entry: a number, or "*" (None) for a coordinate whose end value is free."""
    return None if isinstance(value, str) and value.strip() == "*" else parse_number(value)


Target = Annotated[Coordinate | None, BeforeValidator(_parse_target)]
Name = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=64)]


class _Strict(BaseModel):
    model_config = STRICT


def _parse_start(value: Any) -> float:
    if isinstance(value, str) and value.strip() == "*":
        raise ValueError(
            '"*" (free) is for goals and vias; the start is where the robot is: give every '
            "coordinate"
        )
    return parse_number(value)


class TaskSpec(_Strict):
    start: list[Annotated[Coordinate, BeforeValidator(_parse_start)]] = Field(max_length=1000)
    goal: list[Target] = Field(max_length=1000)


class LegEntry(_Strict):
    stratum: str = Field(max_length=200)
    method: str = Field("newton", max_length=64)  # a name in planners.PLANNERS
    goal: list[Target] | None = Field(None, max_length=1000)
    duration: Annotated[float, Strict(), Field(ge=MIN_DURATION, le=MAX_DURATION)] | None = None
    # method "lie": keys of [planner.lie] overridden for this leg (validated as LieSettings)
    lie: dict[str, Any] | None = None


class ReferenceSpec(_Strict):
    energy: Annotated[float, Strict(), Field(ge=0)] | None = None  # an energy: ∫ Σ u² dt
    source: str = Field("", max_length=1000)


class Scenario(_Strict):
    """A scenario file: what to plan (task, legs or auto mode), on which model, and how."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_-][A-Za-z0-9_.-]*$", max_length=100)]
    description: str = Field("", max_length=10_000)
    model: ModelSpec
    task: TaskSpec
    planner: PlannerSettings = PlannerSettings()
    legs: list[LegEntry] | None = Field(None, min_length=1, max_length=1000)
    decompose: DecomposeSettings | None = None
    reference: ReferenceSpec | None = None
    constraints: ConstraintsSpec | None = None


def load_scenario(source: str | Path | Mapping[str, Any] | Task, name: str | None = None) -> Task:
    """Read, validate and resolve a scenario.

    Parameters
    ----------
    source : str, Path, Mapping or Task
        A path to a TOML file; TOML text (a string with a newline, or an "=" that names no
        file); or a plain `dict` with the same structure as the file (so a sweep never
        templates TOML strings); a `Task` is returned as it is (validated already), as
        `plan` and the other use cases take one.
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
    TypeError
        `source` is none of these.
    """
    if isinstance(source, Task):
        return source
    raw, text, where, folder = read_source(source, name, "scenario")
    return from_raw(raw, text, where, folder)


def parse_scenario(text: str, source: str = "<scenario>", base_dir: Path | None = None) -> Task:
    """`load_scenario` for TOML text; a URDF `path` is relative to `base_dir` (default: cwd)."""
    return from_raw(parse_toml(text, source), text, source, base_dir)


def nulls_as_free(raw: dict[str, Any]) -> dict[str, Any]:
    """`raw` with a null goal entry (how resolved.json and result.json write "*") as "*", so
    that a record's resolved.json loads, and is recorded as TOML, as its scenario did."""

    def free(goal: Any) -> Any:
        return ["*" if v is None else v for v in goal] if isinstance(goal, list) else goal

    raw = dict(raw)
    if isinstance(task := raw.get("task"), dict) and "goal" in task:
        raw["task"] = {**task, "goal": free(task["goal"])}
    if isinstance(legs := raw.get("legs"), list):
        raw["legs"] = [
            {**leg, "goal": free(leg["goal"])} if isinstance(leg, dict) and "goal" in leg else leg
            for leg in legs
        ]
    return raw


def from_raw(
    raw: dict[str, Any], text: str | None, source: str, base_dir: Path | None = None
) -> Task:
    """The `Task` of a scenario's `raw` tables (its `text` as read, or None: written from
    `raw`; `source` names it in messages; `base_dir` resolves its relative paths).

    Raises
    ------
    InputError
        Every problem found, each naming its field.
    """
    if not raw:  # (each required table would be a line of its own)
        raise InputError(
            "the scenario is empty: it needs a name, a [model] and a [task] table "
            "(README: Scenarios)",
            source,
        )
    raw = nulls_as_free(raw)
    if non_finite := reject_non_finite(raw):  # with every other problem of the file
        raise_non_finite(raw, non_finite, lambda r: from_raw(r, None, source, base_dir), source)
    base_dir = (base_dir or Path.cwd()).absolute()  # as now: `with_changes` may run elsewhere
    system, given = None, raw  # (a dict is recorded as given: a URDF's configurations by name)
    if isinstance(raw.get("model"), dict) and raw["model"].get("kind") == "urdf":
        from .models.spatial_scenario import prepare_urdf  # configurations by joint name

        try:
            raw, system = prepare_urdf(raw, base_dir)
        except InputError as exc:
            raise exc.with_source(source) from None
    try:
        scenario = Scenario.model_validate(raw)
    except ValidationError as exc:
        problems = hinted(validation_problems(exc, root=Scenario), raw)
        if system is not None:  # a URDF robot's configurations by name: named as written
            from .models.spatial_scenario import named_paths

            problems = named_paths(problems, given, system)

        def recheck(kept: dict[str, Any]) -> None:
            _resolve(Scenario.model_validate(kept), "", "", system, base_dir)

        problems += beside_refused(raw, exc, problems, recheck)
        raise InputError(problems, source) from None
    if text is None:  # a dict: record it as the TOML file it stands for
        try:
            text = tomlwrite.dumps(given)
        except (TypeError, ValueError) as exc:
            raise InputError(f"cannot be written as TOML: {exc}", source) from None
    try:
        return _resolve(scenario, source, text, system, base_dir)
    except InputError as exc:
        raise exc.with_source(source) from None


def _resolve(
    scenario: Scenario, source: str, text: str, system: System | None = None, base_dir=None
) -> Task:
    if system is None:
        system = build_system(scenario.model)
    system.spec = scenario.model
    n = system.n
    problems: list[Problem] = []
    names = ", ".join(system.states)

    def vector(values: list[float] | None, where: str) -> np.ndarray | None:
        if values is not None and len(values) != n:
            problems.append(Problem(where, f"needs {n} values ({names}), got {len(values)}"))
            return None
        if values is None:
            return None
        return none_to_nan(values)

    start = vector(scenario.task.start, "task.start")
    goal = vector(scenario.task.goal, "task.goal")
    constraints = None
    if scenario.constraints is not None:
        try:
            constraints = resolve(scenario.constraints, system)
        except InputError as exc:
            problems.extend(exc.problems)
    p = scenario.planner
    problems.extend(mode_problems(scenario, system))
    # planners of one's own named by a leg: their modules imported first; a module named in
    # STRATPLAN_PLANNERS that could not be is a problem of its own (first), an installed
    # package's entry point only where a method is still unknown (one broken package's
    # entry point had refused every scenario naming another's planner)
    unknown = any(entry.method not in PLANNERS for entry in scenario.legs or [])
    plugins = [Problem(*p) for p in load_plugins()] if unknown else []
    if not any(entry.method not in PLANNERS for entry in scenario.legs or []):
        plugins = [p for p in plugins if p.path == PLUGINS]
    problems[:0] = plugins
    legs, spans = leg_specs(scenario, system, goal, vector, plugins, problems)
    problems.extend(duration_problems(scenario, legs))
    if not spans:  # (a basis of such periods is degenerate: its conditions say nothing)
        problems.extend(periodic_problems(scenario, system, legs))
        problems.extend(lie_step_problems(scenario, system, legs))
    problems.extend(acceleration_problems(scenario))
    vias = [(f"legs[{i}].goal", leg.goal) for i, leg in enumerate(legs[:-1])]
    problems.extend(attitude_problems(system, [*vias, ("task.goal", goal)]))
    if constraints is not None:
        problems.extend(lie_problems(constraints, legs))
        if start is not None:
            problems.extend(check_configuration(system, start, constraints, "task.start"))
        for i, leg in enumerate(legs[:-1]):
            problems.extend(check_configuration(system, leg.goal, constraints, f"legs[{i}].goal"))
        if goal is not None:
            problems.extend(check_configuration(system, goal, constraints, "task.goal"))
        if goal is not None and not problems:  # (inside the limits, but not by enough)
            problems.extend(cushion_problems(system, legs, constraints))
    if problems:
        raise InputError(list(dict.fromkeys(problems)))  # (each leg's same line: once)
    settings = p
    # auto mode: every stratum the decomposition may use, so that it cannot plan on one
    # where the evaluator asked for does not run
    strata = (
        [leg.stratum for leg in legs]
        if scenario.decompose is None
        else (scenario.decompose.strata or list(system.strata))
    )
    if problems := evaluator_problems(system, p.evaluator, strata):
        raise InputError(problems)

    legs = pinned_vias(system, legs)  # a free via coordinate that later legs keep locked
    check_legs(system, start, legs, settings)
    return Task(scenario, system, start, goal, legs, settings, source, text, constraints, base_dir)


__all__ = [
    "PRESETS",
    "Scenario",
    "Task",
    "build_system",
    "load_scenario",
    "nulls_as_free",
    "parse_scenario",
]
