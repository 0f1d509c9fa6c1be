"""A sweep's base scenario: read from the file its `sweep.scenario` names, an inline
[scenario] table or a notebook's `Task`, and loaded with `sweep.set` applied, so that every
value can be checked against it (`checked_base`)."""

from __future__ import annotations

import copy
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputError, Problem, UnusedLegsWarning
from ..planner_contract import fault
from ..scenario import load_scenario, nulls_as_free
from ..scenario_keys import assign
from ..tomlread import file_tables, parse_toml, read_scenario_text
from .keys import check_scenario, check_value, value_of
from .tables import Base, base_states

if TYPE_CHECKING:
    from .spec import SweepFile

__all__ = ["checked_base", "tasks_as_tables"]


def _base(
    spec: SweepFile, folder: Path, problems: list[Problem]
) -> tuple[dict | None, str, str | None]:
    """The base scenario's tables, how messages name it and its file's text (None: inline)."""
    given = [spec.sweep.scenario is not None, spec.scenario is not None]
    if sum(given) != 1:
        problems.append(
            Problem("sweep.scenario", "give a base scenario: a path here or a [scenario] table")
            if not any(given)
            else Problem("sweep.scenario", "give a path or a [scenario] table, not both")
        )
        return None, "", None
    if spec.scenario is not None:
        return _urdf_from(copy.deepcopy(spec.scenario), folder), "scenario", None
    path = folder / spec.sweep.scenario
    try:
        text = read_scenario_text(path)
        tables = _no_nulls(nulls_as_free(file_tables(text, path, str(path))))  # resolved.json
        return _urdf_from(tables, path.parent), spec.sweep.scenario, text
    except InputError as exc:  # say which file: the path is relative to the sweep file
        given, read = spec.sweep.scenario, os.path.normpath(path)
        where = given if read == os.path.normpath(given) else f"{given} ({read})"
        problems.extend(Problem("sweep.scenario", f"{where}: {p.message}") for p in exc.problems)
        return None, "", None


def _no_nulls(value: Any) -> Any:
    """JSON tables without their null keys (a record's resolved.json writes a default as
    null; TOML has no null and its copy leaves the key out: one base, one digest)."""
    if isinstance(value, dict):
        return {k: _no_nulls(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [_no_nulls(v) for v in value]
    return value


def tasks_as_tables(source: Mapping[str, Any]) -> Mapping[str, Any]:
    """A notebook's `Task` as the base scenario (`{"sweep": {...}, "scenario": task}`, or
    as `sweep.scenario`): its scenario's tables (a URDF path made absolute), as a [scenario]
    table; it was "cannot be written as TOML: cannot write Task to TOML"."""
    from ..task import Task

    sweep = source.get("sweep")
    inner = sweep.get("scenario") if isinstance(sweep, Mapping) else None
    if not isinstance(inner, Task) and not isinstance(source.get("scenario"), Task):
        return source
    out = dict(source)
    if isinstance(inner, Task):  # (given both ways: refused as such, the path as its source)
        out["sweep"] = {**sweep, "scenario": inner.source}
        if "scenario" not in out:
            out["sweep"].pop("scenario")
            out["scenario"] = inner
    task = out["scenario"]
    if isinstance(task, Task):
        out["scenario"] = _urdf_from(parse_toml(task.text, task.source), task.base_dir or Path())
    return out


def _urdf_from(raw: dict[str, Any], folder: Path) -> dict[str, Any]:
    """A base scenario's relative URDF path made relative to its file's `folder` (an inline
    [scenario]: the sweep file's), as when the file is planned alone (its tasks are dicts:
    read from the working directory otherwise)."""
    model = raw.get("model")
    if (
        isinstance(model, dict)
        and model.get("kind") == "urdf"
        and isinstance(model.get("path"), str)
    ):
        model["path"] = str((folder / Path(model["path"]).expanduser()).absolute())
    return raw


def checked_base(spec: SweepFile, pruned: set[tuple], folder: Path, problems) -> Base:
    """The base scenario with `set` applied, loaded: its problems, and what values can be
    checked against (nothing of a base the schema refused: its problem is reported)."""
    s = spec.sweep
    if pruned & {("sweep", "scenario"), ("scenario",)}:
        return Base(None, None, False, pruned, problems)
    base, where, text = _base(spec, folder, problems)
    if base is None:
        return Base(None, None, False, pruned, problems)
    mode = s.mode
    if ("sweep", "mode") in pruned:  # the mode the base is written for: not a second problem
        mode = "legs" if "legs" in base and "decompose" not in base else "auto"
    if mode in ("auto", "compare"):
        if base.pop("legs", None) is not None and ("sweep", "mode") not in pruned:
            warnings.warn(
                f'sweep: mode = "{mode}" decomposes each task afresh, so the base scenario\'s '
                "[[legs]] are not used",
                UnusedLegsWarning,
                stacklevel=2,
            )
        base.setdefault("decompose", {})
    if s.exhaustive and mode != "compare" and ("sweep", "mode") not in pruned:
        problems.append(  # (it was ignored)
            Problem(
                "sweep.exhaustive",
                'applies to mode = "compare" only (its comparison then searches every '
                f'candidate sequence fully), not to mode = "{mode}": remove it or set that mode',
            )
        )
    no_legs = mode == "legs" and "legs" not in base and ("sweep", "mode") not in pruned
    try:
        states = tuple(load_scenario(copy.deepcopy(base), name=where).system.states)
    except InputError as exc:
        found = [_under(where, p) for p in exc.problems if p.path != "legs"]
        if no_legs:
            found.append(_no_legs(where, "mode" in s.model_fields_set))
        problems.extend(found or [_under(where, p) for p in exc.problems])
        hidden = tuple(p.path for p in exc.problems)
        return Base(base, base_states(base), False, pruned, problems, hidden)
    except Exception as exc:  # a planner of one's own that broke checking its legs: a problem
        line = fault(exc, traceback_shown=False)
        if line is None:
            raise
        problems.append(_under(where, Problem("legs", line)))
        return Base(base, base_states(base), False, pruned, problems, ("legs",))
    if no_legs:  # an auto-mode base ([decompose], no legs): every task would be invalid
        problems.append(_no_legs(where, "mode" in s.model_fields_set))
        return Base(base, states, False, pruned, problems)
    applied = 0  # entries of `set` without a problem of their own: the values see them
    for key, value in s.set.items():
        field, before = f'sweep.set."{key}"', len(problems)
        value = value_of(key, value, field, problems)
        check_value(base, key, value, states, field, problems)
        if len(problems) == before:
            try:
                assign(base, key, value, states)
                applied += 1
            except ValueError as exc:
                problems.append(Problem(field, str(exc)))
    before = len(problems)
    if applied:
        check_scenario(base, field="sweep.set", problems=problems)
    loads = len(problems) == before and ("sweep", "set") not in pruned
    return Base(base, states, loads, pruned, problems, text=text)


def _no_legs(where: str, given: bool = True) -> Problem:
    """Legs mode (the default, unless `given`) over a base without [[legs]]."""
    named = "the [scenario] table" if where == "scenario" else where
    mode = "legs mode" if given else "legs mode (the default, where no mode is given)"
    why = f"{mode} plans the base scenario's [[legs]], and {named} has none"
    return Problem("sweep.mode", f'{why}: set mode = "auto" or "compare"')


def _under(where: str, p: Problem) -> Problem:
    """A problem of the base scenario: under [scenario], or in the file sweep.scenario names."""
    if where == "scenario":
        return Problem(f"scenario.{p.path}" if p.path else "scenario", p.message)
    return Problem("sweep.scenario", f"{where}: {p.path}: {p.message}" if p.path else p.message)
