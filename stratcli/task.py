"""A loaded scenario, ready to plan (`Task`): a value resolved from its scenario's tables,
changed only through them (`Task.with_changes`), so that a record holds what was planned."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .arguments import wrong_type
from .errors import InputError
from .models.specs import model_states
from .results import none_to_nan
from .scenario_keys import assign, changes_task, holds, is_coordinate, key_parts
from .tomlread import parse_toml, plain

if TYPE_CHECKING:
    from .constraints import Constraints
    from .models.system import System
    from .scenario import Scenario
    from .settings import PlannerSettings
    from .stratified import LegSpec

__all__ = ["Task", "model_name"]


def model_name(spec) -> str:
    """A [model] table's name in records: the preset's, else its kind ("planar-manipulator",
    "custom", "urdf")."""
    return spec.name if spec.kind == "preset" else spec.kind


@dataclass(frozen=True, eq=False)
class Task:
    """A validated scenario, ready to plan: a value, resolved from `scenario` (its start,
    goal, legs and settings), which records write as they were planned. To change it, use
    `with_changes` (validated and resolved again); a `dataclasses.replace` that lets the
    settings, start, goal, legs' strata or constraints disagree with `scenario` is refused.

    Two tasks are equal when their scenarios are (what is planned follows from it), whatever
    they were read from (`source`, `text`: a path, its TOML text or a dict); tasks hash
    accordingly, so they can key a dict or fill a set.

    Attributes
    ----------
    scenario : Scenario
        The validated scenario tables, defaults filled in.
    system : System
        The model (a preset is one object shared by every task of it).
    start, goal : ndarray
        Configurations (read-only); `goal` is NaN where free ("*").
    legs : tuple of LegSpec
        The legs to plan (empty in auto mode: a [decompose] table).
    settings : PlannerSettings
        The [planner] table.
    source, text : str
        Where the scenario came from (a path, "<text>", "<dict>") and its TOML text.
    constraints : Constraints or None
        The [constraints] table resolved on the model (None: no table).
    base_dir : Path or None
        What a URDF model's relative path is relative to.
    """

    scenario: Scenario
    system: System
    start: np.ndarray
    goal: np.ndarray
    legs: tuple[LegSpec, ...]  # a tuple: a list's .reverse() planned what records do not say
    settings: PlannerSettings
    source: str
    text: str
    constraints: Constraints | None = None  # the [constraints] table, resolved on the model
    base_dir: Path | None = None  # what a URDF model's relative path is relative to

    def __post_init__(self):
        object.__setattr__(self, "legs", tuple(self.legs))
        given, entries = self.scenario.task, self.scenario.legs or []
        if (
            self.settings != self.scenario.planner
            or not _same(self.start, given.start)
            or not _same(self.goal, given.goal)
            or [leg.stratum for leg in self.legs] != [entry.stratum for entry in entries]
            or (self.constraints is None) != (self.scenario.constraints is None)
            or not self._constraints_are_the_scenarios()
        ):
            raise ValueError(
                "a Task's settings, start, goal, legs and constraints are its scenario's: "
                "change them with task.with_changes({...}) (e.g. {'planner': {'objective': "
                "'newton'}})"
            )
        self._read_only()

    def _constraints_are_the_scenarios(self) -> bool:
        """Whether `constraints` is the scenario's [constraints] table resolved on the model:
        limits changed by `dataclasses.replace` were planned while the record said the
        table's (and its goals were never checked against them)."""
        if self.constraints is None:
            return True
        from .constraints import resolve  # (the scenario module resolved them the same way)

        try:
            return resolve(self.scenario.constraints, self.system) == self.constraints
        except InputError:  # a table the model refuses: a Task is never made of one
            return False

    def __repr__(self) -> str:  # the dataclass's runs to many kB (the model's fields, text)
        legs = ", ".join(leg.stratum for leg in self.legs)
        limits = ", [constraints]" if self.constraints is not None else ""
        return (  # the objective: a task changed to the other one read as the same
            f"Task({self.scenario.name!r}: {self.system.name} model, "
            f"{f'legs ({legs})' if legs else 'auto mode'}, {self.settings.objective} "
            f"objective{limits}, start {_vector(self.start)}, goal {_vector(self.goal)})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Task):
            return NotImplemented
        return self is other or self.scenario == other.scenario

    def __hash__(self) -> int:
        return hash(_frozen(self.scenario.model_dump()))

    def __setstate__(self, state: dict) -> None:  # unpickled arrays are writable again
        self.__dict__.update(state)
        self._read_only()

    def _read_only(self) -> None:
        for array in (self.start, self.goal, *(leg.goal for leg in self.legs)):
            if array is not None:  # t.goal[0] = ... would plan what the records do not say
                array.setflags(write=False)

    @property
    def model_name(self) -> str:
        """Preset name, "planar-manipulator" or "custom" (the result.json `model` key)."""
        return model_name(self.scenario.model)

    def with_changes(self, changes: Mapping[str, Any]) -> Task:
        """This scenario with `changes`, validated and resolved again (as `load_scenario`).

        Parameters
        ----------
        changes : Mapping
            In the scenario file's structure. Tables are merged key by key, anything else
            (a value, a list such as `legs`) replaces what was there; None removes the key.
            E.g. ``{"planner": {"objective": "newton"}, "task": {"goal": [0, 1, 0.5, 0]}}``.
            A key may also be a sweep's (`scenario_keys`): a dotted path
            (``"planner.tolerance"``, ``"constraints.obstacles[0].centre[1]"``) or a
            coordinate by name (``"goal.q1"``, ``"legs[0].goal.theta"``; a URDF robot's
            ``"goal.j2"``, ``"goal.rz"``), set after the nested ones; one place given both
            ways is refused. A change of the task, legs or model drops the scenario's
            [reference] energy (the paper's, for its own task) unless `changes` gives one.

        Returns
        -------
        Task
            A new task (this one is unchanged); its records hold the changed scenario.

        Raises
        ------
        InputError
            Naming every problem of the changed scenario.
        TypeError
            `changes` is not a mapping.
        """
        from .scenario import from_raw  # (which builds tasks)

        if not isinstance(changes, Mapping):
            raise wrong_type("changes", "a mapping (a dict)", changes)
        where = f"{self.source} (with changes)"  # the file itself may be fine

        def states(raw: dict[str, Any]) -> tuple[str, ...]:  # of a changed [model]
            found = model_states(raw.get("model"), self.base_dir)
            if found is None:  # it does not build: loading it names why
                return from_raw(raw, None, self.source, self.base_dir).system.states
            return found

        try:  # numpy values as Python's, as a dict given to `load_scenario`
            raw = _changed(parse_toml(self.text, self.source), plain(changes), self.system, states)
        except InputError as exc:
            raise exc.with_source(where) from None
        try:
            return from_raw(raw, None, self.source, self.base_dir)
        except InputError as exc:  # (ModelError included: the same problems, re-sourced)
            raise exc.with_source(where) from None


def _vector(values: np.ndarray) -> str:
    """A configuration in a repr: 4 significant digits, `*` where any value will do."""
    return "[" + ", ".join("*" if v != v else f"{v:.4g}" for v in values) + "]"


def _frozen(value: Any) -> Any:
    """`value` (a scenario's `model_dump`) as nested tuples that hash as it compares: equal
    values, equal hashes (0.0 and -0.0, 1 and 1.0 too); a NaN as one constant, since a NaN
    compares equal to itself by identity in a list or dict but hashes by identity."""
    if isinstance(value, Mapping):
        return tuple(sorted((str(k), _frozen(v)) for k, v in value.items()))
    if isinstance(value, list | tuple):
        return tuple(_frozen(v) for v in value)
    if isinstance(value, float) and value != value:
        return "nan"
    return value


def _same(values: np.ndarray | None, given: list | None) -> bool:
    if values is None or given is None:
        return values is None and given is None
    resolved = none_to_nan(given)
    return resolved.shape == np.shape(values) and bool(
        np.array_equal(resolved, values, equal_nan=True)
    )


def _changed(raw: dict[str, Any], changes: Mapping[str, Any], system, states_of) -> dict:
    """`raw` with `changes` (`Task.with_changes`): nested ones merged, then a sweep's keys
    (`scenario_keys.assign`; the model's coordinates name a vector's entries: `system`'s, or
    where the changes change the [model], `states_of(raw)` once its keys are in: a model's
    keys come first, so that `{"model.name": "two-arm", "goal.q4": 1}` finds q4)."""
    keyed = {k: v for k, v in changes.items() if isinstance(k, str) and ("." in k or "[" in k)}
    nested = {k: v for k, v in changes.items() if k not in keyed}
    out = copy.deepcopy(_merged(raw, nested))
    other = any(k in ("task", "legs", "model") for k in nested) or any(
        _quietly(changes_task, k) for k in keyed
    )
    if other and "reference" not in changes:  # another task: not the paper's (as a sweep's)
        out.pop("reference", None)
    model = [k for k in keyed if _quietly(lambda k: key_parts(k)[0] == "model", k)]
    keyed = {k: keyed[k] for k in [*model, *(k for k in keyed if k not in model)]}
    states, changed = system.states, bool(model) or "model" in nested
    for key, value in keyed.items():
        if changed and _quietly(is_coordinate, key):
            states, changed = states_of(out), False  # (the model's keys are in: first)
        try:
            parts = key_parts(key)
            if _covers(nested, parts):
                raise ValueError("given twice, as this key and in a nested table")
            if value is None and is_coordinate(key):
                raise ValueError('None removes a table\'s key; "*" leaves a coordinate free')
            if value is None:  # removes the key, as a nested None does
                _remove(out, parts)
            else:
                assign(out, key, value, tuple(states))
        except ValueError as exc:
            raise InputError(f"{key}: {exc}") from None
    return out


def _quietly(test, key: str) -> bool:
    """`test(key)`, False for a key that is no dotted name (its error comes after)."""
    try:
        return test(key)
    except ValueError:
        return False


def _remove(raw: dict[str, Any], parts: list) -> None:
    """Remove the table key `parts` names (absent: nothing to remove)."""
    node: Any = raw
    for part in parts[:-1]:
        if not holds(node, part):
            return
        node = node[part]
    if not isinstance(node, dict) or isinstance(parts[-1], int):
        raise ValueError("None removes a table's key, not an entry of a list or vector")
    node.pop(parts[-1], None)


def _covers(nested: Any, parts: list) -> bool:
    """Whether the nested changes set the place `parts` names (or a value holding it)."""
    for part in parts:
        if not isinstance(nested, dict | list) or (
            isinstance(nested, list) and isinstance(part, str)
        ):
            return True  # a vector or value set whole holds it
        if not holds(nested, part):
            return False
        nested = nested[part]
    return True


def _merged(raw: dict[str, Any], changes: Mapping[str, Any]) -> dict[str, Any]:
    """`raw` with `changes` merged in; neither is modified."""
    out = dict(raw)
    for key, value in changes.items():
        if value is None:
            out.pop(key, None)
        elif isinstance(value, Mapping) and isinstance(out.get(key), dict):
            kept = out[key]
            for given, other in (("rpy", "attitude"), ("attitude", "rpy")):  # a URDF's, whole
                if given in value and other not in value:  # (else "give either ..., not both")
                    kept = {k: v for k, v in kept.items() if k != other}
            out[key] = _merged(kept, value)
        else:
            out[key] = value
    return out
