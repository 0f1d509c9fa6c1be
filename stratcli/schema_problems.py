"""Pydantic's validation errors as the one-line problems users read (`file: field: message`).

Locations become dotted paths as written in the file (`legs[1].goal`, without the tags pydantic
adds for a member of a discriminated union: `obstacles[0].centre`), an unknown key lists
the keys allowed in its table, a model table without a valid `kind` names the kinds.
"""

from __future__ import annotations

import difflib
import re
from typing import Any, Literal, get_args, get_origin

from pydantic import BaseModel, ValidationError

from .errors import Problem
from .models.specs import KINDS
from .settings import UNKNOWN_KEY_ERRORS
from .wording import closest_choice

__all__ = ["file_location", "suggested", "validation_problems"]


def _path(loc: tuple) -> str:
    parts: list[str] = []
    for i, item in enumerate(loc):
        if isinstance(item, int) and parts:
            parts[-1] = f"{parts[-1]}[{item}]"
        elif isinstance(item, int):  # a top-level key that is a number (a dict, not a file)
            parts.append(str(item))
        elif i > 0 and loc[i - 1] == "model" and item in KINDS:
            continue  # pydantic's tag of the discriminated union, not a key of the file
        else:  # a sweep's key holds dots: quoted, as the other problems of its axis are
            parts.append(f'"{item}"' if "." in str(item) else str(item))
    return ".".join(parts)


def _fields_of(cls: Any) -> dict[str, Any] | None:
    """Field name → annotation of a schema class (pydantic model or pydantic dataclass)."""
    if isinstance(cls, type) and issubclass(cls, BaseModel):
        return {k: f.annotation for k, f in cls.model_fields.items()}
    fields = getattr(cls, "__pydantic_fields__", None)
    return None if fields is None else {k: f.annotation for k, f in fields.items()}


def _allowed_keys(root: Any, loc: tuple) -> list[str]:
    """Keys allowed at the table that holds `loc[-1]`, by walking the schema from `root`."""
    found = _walk(root, loc[:-1])
    members = _members(found[0]) if found else []
    return list(_fields_of(members[0]) or {}) if len(members) == 1 else []


def _walk(root: Any, loc: tuple) -> tuple[Any, tuple] | None:
    """(the annotation at `loc` in the schema `root`, `loc` without the tags of discriminated
    unions, which pydantic adds and the file does not have: `obstacles[0].circle.centre` is
    `obstacles[0].centre`); None where the schema has no such place."""
    ann, kept = root, []
    for item in loc:
        if isinstance(item, int):  # an item of a list: its members are those of the list
            kept.append(item)
            continue
        members = _members(ann)
        fields = next((f for m in members if item in (f := _fields_of(m) or {})), None)
        if fields is not None:
            ann = fields[item]
            kept.append(item)
            continue
        tagged = [m for m in members if item in _tags(m)]
        if not tagged:
            values = _dict_values(ann)  # a key of a table of any keys (sweep.grid's)
            if values is None:
                return None
            ann = values
            kept.append(item)
            continue
        ann = tagged[0]  # a union's member, chosen by its tag: not a key of the file
    return ann, tuple(kept)


def _dict_values(ann: Any) -> Any:
    """The value annotation of a `dict[str, V]` (through Annotated and Optional), or None."""
    if get_origin(ann) is dict:
        return get_args(ann)[1]
    found = [v for a in get_args(ann) if (v := _dict_values(a)) is not None]
    return found[0] if len(found) == 1 else None


def _members(ann: Any) -> list[Any]:
    """The schema classes an annotation may hold (through Annotated, unions, lists, dicts)."""
    if ann is None:
        return []
    if _fields_of(ann) is not None:
        return [ann]
    return [m for a in get_args(ann) for m in _members(a)]


def _tags(cls: Any, field: str | None = None) -> tuple[str, ...]:
    """The literal values of `cls`'s field `field` (of any field without one): a member's tags."""
    fields = _fields_of(cls) or {}
    names = [field] if field is not None else list(fields)
    return tuple(
        v for n in names if get_origin(fields.get(n)) is Literal for v in get_args(fields[n])
    )


_PATTERNS = {  # the schema's patterns, in words
    r"^[A-Za-z0-9_-][A-Za-z0-9_.-]*$": "must be ASCII letters, digits, '_', '.' and '-' only, "
    "no spaces, not starting with '.' (it names the run records and files)",
    r"^[A-Za-z_][A-Za-z0-9_]*$": "must be a name of ASCII letters, digits and '_', not starting "
    "with a digit (it is used in expressions and as a column name)",
}
_BOUNDS = {  # pydantic's bound errors, in words
    "greater_than": "more than",
    "greater_than_equal": "at least",
    "less_than": "less than",
    "less_than_equal": "at most",
}
PYDANTIC_VOICE = "Input should be "


def validation_problems(
    exc: ValidationError, prefix: tuple = (), root: Any = None
) -> list[Problem]:
    """One `Problem` per error of `exc`, at `prefix` + its location; unknown keys list the keys
    allowed there, found by walking the schema class `root` (none without it).

    A value that may take several forms (a number or a list, say) fails each of them:
    pydantic names the forms in the location (`function-after[...]`, `list[...]`, a class
    name); they are left out of the path, and a form the value is not even of the type of is
    not reported beside one it is."""
    out, alternatives, models = [], {}, _model_names()
    meant, missing = set(), []  # keys an unknown key is a misspelling of; missing keys
    for err in exc.errors():
        raw = prefix + tuple(err["loc"])
        kind = err["type"]
        unknown = kind in UNKNOWN_KEY_ERRORS  # a key the schema has not: its table's is walked
        # (an unknown key is the file's own, whatever it looks like: "legs[0]" is no form)
        loc = file_location(raw[:-1], models) + raw[-1:] if unknown else file_location(raw, models)
        walked = _walk(root, loc[:-1] if unknown else loc) if root is not None else None
        where = _path((*walked[1], *loc[-1:]) if unknown else walked[1]) if walked else _path(loc)
        if unknown:
            allowed = _allowed_keys(root, loc) if root is not None else []
            hint = f" (allowed: {', '.join(allowed)})" if allowed else ""
            near = difflib.get_close_matches(str(loc[-1]), allowed, n=1, cutoff=0.75)
            typo = f": did you mean {near[0]!r}?" if near else ""  # tolerence, tolerance
            if near:
                table = where.rpartition(".")[0]
                meant.add(f"{table}.{near[0]}" if table else near[0])
            out.append(Problem(where, f"unknown key{typo}{hint}"))
            continue
        msg = err["msg"].removeprefix("Value error, ")
        if msg.startswith(PYDANTIC_VOICE):  # "Input should be ...": as every other message
            msg = "must be " + msg.removeprefix(PYDANTIC_VOICE)
        if kind in _BOUNDS and "ctx" in err:  # pydantic writes 1e-12 as 0.000000000001
            bound = next(iter(err["ctx"].values()))
            limit = f"{bound:g}" if isinstance(bound, float) else str(bound)
            msg = f"must be {_BOUNDS[kind]} {limit}"
        if kind == "missing":
            msg = "required field is missing"
        if kind == "string_pattern_mismatch":  # pydantic: "String should match pattern '^[...'"
            pattern = str(err.get("ctx", {}).get("pattern", ""))
            msg = _PATTERNS.get(pattern, f"must match the pattern {pattern}")
        if kind == "string_too_long" and "ctx" in err:  # "String should have at most 100..."
            msg = f"must be at most {err['ctx'].get('max_length')} characters long"
        if kind in ("too_short", "too_long") and "ctx" in err:  # "List should have at least..."
            ctx = err["ctx"]
            bound = ctx.get("min_length", ctx.get("max_length"))
            least = "at least" if kind == "too_short" else "at most"
            entries = "entry" if bound == 1 else "entries"
            msg = f"must have {least} {bound} {entries}, not {ctx.get('actual_length')}"
        if kind in ("union_tag_not_found", "union_tag_invalid"):  # a table without a valid tag
            ctx = err.get("ctx", {})
            field = ctx.get("discriminator", "kind").strip("'")
            got = err["input"].get(field) if isinstance(err["input"], dict) else None
            tags = ctx.get("expected_tags")
            if tags:
                tags = ", ".join(t.strip(" '") for t in tags.split(","))
            else:  # pydantic names none: the union's own members do
                found = _walk(root, loc) if root is not None else None
                own = [t for m in _members(found[0]) for t in _tags(m, field)] if found else []
                tags = ", ".join(own or KINDS)
            what = "is missing" if got is None else f"is {_short(got)}, not a {field}"
            choices = tags.split(", ")
            near = [t for t in choices if isinstance(got, str) and t.lower() == got.lower()]
            if not near and isinstance(got, str):  # 'URDF', 'planar_manipulator', 'planar'
                near = difflib.get_close_matches(got.lower(), choices, n=1, cutoff=0.75)
                near = near or [t for t in choices if got and t.startswith(got.lower())][:1]
            meant = f": did you mean {near[0]!r}?" if near else ""
            out.append(Problem(f"{where}.{field}", f"{what} (one of: {tags}){meant}"))
            continue
        # a validator's own message may show the value already (parse_number's do)
        shown = "" if kind == "missing" or "(got " in msg else f" (got {_short(err['input'])})"
        if kind in ("float_type", "int_type") and _quoted_number(err.get("input")):
            shown += ": a number is written without quotes"  # tolerance = "1e-3"
        if kind in ("model_type", "model_attributes_type", "dict_type", "dataclass_type"):
            msg = "must be a table"  # (TOML's words: "a valid dictionary" is Python's)
        if kind == "list_type":
            msg = "must be a list"
        problem = Problem(where, suggested(f"{msg}{shown}", err.get("input")))
        if loc != raw:  # one form of several: grouped by the value they are forms of
            at = next(i for i, item in enumerate(raw) if _form(item, models))
            # a form that a part of the value is not even of the type of (a number's parser
            # given a list: max_rate = [1, 0, 1] is no number) does not fit the value
            misfit = kind in _WRONG_TYPE or (
                isinstance(err.get("input"), list | dict) and msg.startswith(NOT_A_NUMBER)
            )
            depth = len(raw) - at  # how far into the value this form got before its error
            form = (kind, problem, msg, shown, raw[at], misfit, depth)
            alternatives.setdefault(raw[:at], []).append(form)
            continue
        if kind == "missing":
            missing.append(problem)
        out.append(problem)
    for found in alternatives.values():
        out.extend(_fitting(found))
    # a key misspelt is not also missing: `task.gaol: unknown key: did you mean 'goal'?`
    # says it all, without `task.goal: required field is missing` beside it
    # (one form's missing key too: `linspace` of a grid axis, a list or a table)
    missing += [p for p in out if p.message == "required field is missing"]
    dropped = {p for p in missing if p.path in meant}
    return [p for p in out if p not in dropped]


def _fitting(found: list[tuple]) -> list[Problem]:
    """The problems of the forms that fit a value best, of (kind, problem, message, value
    shown, form, misfit, depth) of each error: forms without a misfit (a part of the value
    not even of their type), and of those the ones that got furthest into the value (a list
    of pairs with one short pair is a list of pairs: `[1]: must have at least 2 entries`,
    not also a pair `must have at most 2 entries, not 3`); else one line naming them all."""
    misfits = {f[4] for f in found if f[5]}
    fitting = [f for f in found if f[4] not in misfits]
    if not fitting:  # a form whose own type the value is, erring inside it, is the one
        inside = [f for f in found if f[6] > 1 and f[6] == max(g[6] for g in found)]
        if inside:  # (`{ q2 = [1, 2] }` is a table of the by-name form, not a number)
            return list(dict.fromkeys(f[1] for f in inside))
        return _one_of([f[:4] for f in found])
    reach = {form: min(f[6] for f in fitting if f[4] == form) for form in {f[4] for f in fitting}}
    furthest = max(reach.values())
    return list(dict.fromkeys(f[1] for f in fitting if reach[f[4]] == furthest))


def _one_of(forms: list[tuple]) -> list[Problem]:
    """A value of none of a field's forms' types in one line: "must be a list or a table
    (got 2.5)", where each form said its own ("must be a list (got 2.5)", then "must be a
    table (got 2.5)"). `forms`: (kind, problem, its message
    without the value shown, the value shown) of each."""
    forms = [  # a number's parser given another type: "must be a number" as a form
        (k, p, "must be a number", m[m.rfind(" (got ") :] if " (got " in m else s)
        if m.startswith(NOT_A_NUMBER)
        else (k, p, m, s)
        for k, p, m, s in forms
    ]
    problems = list(dict.fromkeys(p for _, p, _, _ in forms))
    wanted = list(dict.fromkeys(msg.removeprefix("must be ") for _, _, msg, _ in forms))
    shown = {s for _, _, _, s in forms}
    one = len({p.path for p in problems}) == 1 and len(shown) == 1 and "" not in shown
    if len(problems) < 2 or not one or not all(m.startswith("must be ") for _, _, m, _ in forms):
        return problems
    return [Problem(problems[0].path, f"must be {' or '.join(wanted)}{shown.pop()}")]


def file_location(loc: tuple, models: set[str] | None = None) -> tuple:
    """A pydantic error's location as written in the file: keys and indices, without the
    forms of a value that may take several (`_form`; `models`: `_model_names()`)."""
    models = _model_names() if models is None else models
    return tuple(item for item in loc if not _form(item, models))


NOT_A_NUMBER = "expected a number or an expression"  # `parse_number`'s refusal of a type
_WRONG_TYPE = {
    "list_type", "dict_type", "model_type", "model_attributes_type", "float_type", "int_type",
    "string_type", "bool_type", "is_instance_of", "dataclass_type", "tuple_type",
}  # fmt: skip


def _form(item: Any, models: set[str]) -> bool:
    """Whether a location item names one form of a value (pydantic's union member tags: a
    validator's or a generic's repr, or a model class's name), not a key of the file (which
    may well start with a capital: a custom model's parameter `M`)."""
    return isinstance(item, str) and (any(c in item for c in "[(") or item in models)


def _model_names() -> set[str]:
    """Names of every pydantic model class defined so far (the tags of model members)."""
    names, todo = set(), [BaseModel]
    while todo:
        cls = todo.pop()
        for sub in cls.__subclasses__():
            if sub.__name__ not in names:
                names.add(sub.__name__)
                todo.append(sub)
    return names


def suggested(message: str, got: Any) -> str:
    """`message` ("must be 'a' or 'b' (got 'x')") with the choice closest to the string
    given, if one is: the same letters in another case ('Newton', 'lr-c1'), a close
    spelling ('optimize' for 'optimise'), or the same letters in another order ('lei')."""
    choices = re.findall(r"'([^']*)'", message.partition(" (got ")[0])
    if not message.startswith("must be '") or not isinstance(got, str) or not choices:
        return message
    near = closest_choice(got, choices)
    if near is None or not message.endswith(")"):
        return message
    return f"{message[:-1]}: did you mean {near!r}?)"


def _quoted_number(value: Any) -> bool:
    """Whether `value` is text that reads as a number ("1e-3", " 5 "): a quoted number."""
    try:
        return isinstance(value, str) and bool(value.strip()) and float(value) == float(value)
    except ValueError:
        return False


def _short(value: Any) -> str:
    """repr of an offending value, cut to one readable line."""
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."
