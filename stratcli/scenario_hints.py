"""Hints added to the validation problems of a scenario for the mistakes that are easy to make
and that pydantic's own words do not explain: a single `[legs]` table, a single obstacle
table for the list of obstacles, a configuration written as a table of names on a model that
is not a URDF robot (on a URDF robot whose
`[model]` table is invalid, that table cannot be read yet: only the model's problems stand),
and a model object (a `System`) given from Python instead of its table; and the problems that
only the model shows (a locked joint, a coordinate a limit names), beside the schema's."""

from __future__ import annotations

import copy
import re
from typing import Any

from pydantic import ValidationError

from .errors import InputError, Problem
from .scenario_keys import holds
from .schema_problems import file_location

__all__ = ["beside_refused", "hinted"]

_LIST = "must be a list"
_MODEL_OBJECT = (
    "must be a [model] table (a dict with its kind: preset, custom, planar-manipulator or "
    "urdf), not a {} object; a model of your own is given by its table"
)
_PLAIN = (dict, list, str, int, float)  # what a file holds: pydantic's own words fit those
_CONFIGURATION = re.compile(r"^(task\.(start|goal)|legs\[\d+\]\.goal)$")


def hinted(problems: list[Problem], raw: dict[str, Any]) -> list[Problem]:
    """`problems` with a hint where a table was given for a list (`raw` is the file, after
    `prepare_urdf` has turned a URDF model's named configurations into lists)."""
    model = raw.get("model")
    urdf = isinstance(model, dict) and model.get("kind") == "urdf"
    model_broken = any(p.path == "model" or p.path.startswith("model.") for p in problems)
    kind_broken = any(p.path == "model.kind" for p in problems)  # which model is not known
    if model_broken and model is not None and not isinstance(model, _PLAIN):
        # a model object (`stratcli.preset(...)`, a `PlanarManipulator`): pydantic reads its
        # attributes and says `model.kind: is missing`, which does not say what to give
        problems = [p for p in problems if p.path != "model" and not p.path.startswith("model.")]
        problems.insert(0, Problem("model", _MODEL_OBJECT.format(type(model).__name__)))
    table = raw.get("constraints")
    one_obstacle = isinstance(table, dict) and isinstance(table.get("obstacles"), dict)
    out = []
    for p in problems:
        hint = None
        if p.message.startswith(_LIST) and p.path == "legs" and isinstance(raw.get("legs"), dict):
            hint = "write [[legs]] (an array of tables), one per leg"
        elif p.message.startswith(_LIST) and p.path == "constraints.obstacles" and one_obstacle:
            hint = (
                "write a list, even of one: obstacles = [{ shape = ... }], or one "
                "[[constraints.obstacles]] table per obstacle"
            )
        elif p.path == "legs" and raw.get("legs") == []:  # a notebook's `"legs": []`
            hint = (
                "for auto mode to choose the legs, give a [decompose] table instead "
                "(from Python: with_changes({'legs': None, 'decompose': {}}))"
            )
        elif (
            model_broken
            and _CONFIGURATION.match(p.path)
            and (urdf or (kind_broken and isinstance(_at(raw, p.path), dict)))
        ):  # by name may be right (a URDF robot's; `kind = "URDF"` may be one): read once
            continue  # the model loads; its problem is listed
        elif p.message.startswith(_LIST) and _CONFIGURATION.match(p.path):
            order = _coordinates(raw.get("model"))
            given = _at(raw, p.path)
            if isinstance(given, str):  # "0, pi/4, 0, 0": one string, not a list
                hint = f"write a list of the model's coordinates in order {order}, not one string"
            elif not isinstance(given, dict):  # `start = 0`: no table to speak of
                hint = f"write a list of the model's coordinates in order {order}"
            else:
                hint = (
                    "a configuration by name (a table) is for URDF models only; write a list "
                    f"of the model's coordinates in order {order}"
                )
        if hint is not None:
            head, got, tail = p.message.partition(" (got ")
            p = Problem(p.path, f"{head}: {hint}{got}{tail}")
        out.append(p)
    return out


def _at(raw: dict[str, Any], path: str) -> Any:
    """The value at a problem's path (`task.start`, `legs[1].goal`) in the file, or None."""
    value: Any = raw
    for key, index in re.findall(r"([^.\[\]]+)(?:\[(\d+)\])?", path):
        value = value.get(key) if isinstance(value, dict) else None
        if index and isinstance(value, list):
            value = value[int(index)] if int(index) < len(value) else None
    return value


def _coordinates(model: Any) -> str:
    """The coordinates of the scenario's model in parentheses: built from it, else its
    `states` as written, else the model's first problem (to be fixed before anything else,
    `stratplan models FILE` included)."""
    from pydantic import TypeAdapter

    from .models.specs import ModelSpec, build_system
    from .schema_problems import validation_problems

    try:
        return f"({', '.join(build_system(TypeAdapter(ModelSpec).validate_python(model)).states)})"
    except ValidationError as exc:
        first = validation_problems(exc, ("model",))[0]
    except InputError as exc:
        first = exc.problems[0]
    states = model.get("states") if isinstance(model, dict) else None
    if isinstance(states, list) and states and all(isinstance(s, str) for s in states):
        return f"({', '.join(states)})"
    return f"(fix the model first: {first.render()})"


def beside_refused(raw, exc: ValidationError, reported, recheck) -> list[Problem]:
    """What else a scenario whose schema refused some values has: the scenario without them
    validated and resolved against its model (a leg's goal on a locked joint, a coordinate a
    limit names), as one run reports every problem (they came only once the schema's were
    fixed: `soft_start = "yes"` hid a locked joint). Each refused key is left out (a value in
    a list: the list's key); where that leaves a required key missing, nothing more can be
    checked. Nothing that names a refused key is added (its absence is no second problem).
    `recheck(raw)` validates and resolves a scenario, raising `InputError`."""
    kept, refused = copy.deepcopy(raw), set()
    for error in exc.errors():
        loc = file_location(tuple(error["loc"]))
        while loc and isinstance(loc[-1], int):  # a value in a list: the list's key
            loc = loc[:-1]
        if not loc or error["type"] == "missing":
            return []  # the whole scenario, or a key it needs: nothing more to check
        node: Any = kept
        for part in loc[:-1]:
            node = node[part] if holds(node, part) else None
        if isinstance(node, dict):
            node.pop(loc[-1], None)
        refused.add(str(loc[-1]))
    try:
        recheck(kept)  # the scenario loaded as far as its model and values
    except InputError as more:
        seen = {(p.path, p.message) for p in reported}

        def new(p: Problem) -> bool:
            said = f"{p.path} {p.message}"
            return (p.path, p.message) not in seen and not any(k in said for k in refused)

        return [p for p in more.problems if new(p)]
    except (ValidationError, ValueError, TypeError):  # not checkable without the refused keys
        return []
    return []
