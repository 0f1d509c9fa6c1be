"""Sweep files: TOML validated with pydantic, expanded into one scenario dict per task.

A sweep file is a base scenario (a path, or an inline ``[scenario]`` table) plus what varies::

    [sweep]
    name = "goal_map"
    scenario = "../sim4_auto.toml"      # relative to the sweep file; or an inline [scenario]
    mode = "auto"                       # legs | auto | compare
    set = { "planner.objective" = "newton" }   # applied to every task

    [sweep.grid]                        # the product of the axes, first axis slowest
    "goal.q1" = { linspace = ["-pi/2", 0, 21] }
    "goal.theta" = [-0.5, 0.0, 0.5]

or ``[sweep.random]`` (``count``, ``seed``, ``ranges = { "goal.q1" = [lo, hi] }``, uniform;
task k draws from ``SeedSequence(seed, spawn_key=(k,))`` and plans with a seed drawn from it),
or an explicit ``[[sweep.task]]`` table of ``key = value`` rows.

A key names a scenario value: ``start.NAME``, ``goal.NAME`` and ``legs[i].goal.NAME`` are
coordinates (NAME a coordinate of the model, e.g. ``q1`` or ``theta``; ``task.`` may be
written in front), anything else a dotted path into the scenario (``planner.tolerance``,
``decompose.max_length``). Problems are reported as the scenario's are: one line each,
naming the field (`stratcli.errors.InputError`, exit 2).
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, Field, ValidationError

from .. import tomlwrite
from ..errors import InputError, Problem
from ..models.specs import STRICT
from ..scenario import load_scenario
from ..schema_problems import validation_problems
from ..tomlread import parse_toml, read_scenario_text, read_source, reject_non_finite
from .keys import (
    MAX_TASKS,
    assign,
    axis_values,
    check_scenario,
    check_value,
    check_values,
    is_coordinate,
    key_problem,
    number,
    valid_key,
    value_of,
)

MODES = ("legs", "auto", "compare")
MAX_CHECKED = 200  # values of one axis checked by loading the scenario with them
Name = Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+$", max_length=100)]


class Linspace(BaseModel):
    model_config = STRICT
    linspace: list[Any] = Field(min_length=3, max_length=3)


class RandomSpec(BaseModel):
    model_config = STRICT
    count: Annotated[int, Field(ge=1, le=MAX_TASKS)]
    seed: Annotated[int, Field(ge=0, lt=2**63)] = 0
    ranges: dict[str, list[Any]] = Field(min_length=1)


class SweepSpec(BaseModel):
    model_config = STRICT
    name: Name
    description: str = Field("", max_length=10_000)
    scenario: str | None = Field(None, max_length=4096)
    mode: Literal["legs", "auto", "compare"] = "legs"
    check: bool = True  # controllability check of each task (as `stratplan plan`)
    exhaustive: bool = False  # compare mode: every candidate searched to its minimum
    set: dict[str, Any] = {}
    grid: dict[str, list[Any] | Linspace] | None = Field(None, min_length=1)
    random: RandomSpec | None = None
    task: list[dict[str, Any]] | None = Field(None, min_length=1, max_length=MAX_TASKS)


class SweepFile(BaseModel):
    model_config = STRICT
    sweep: SweepSpec
    scenario: dict[str, Any] | None = None


@dataclass(frozen=True)
class SweepTask:
    """One task of a sweep: its index, the values it varies, its seed and its scenario."""

    index: int
    inputs: dict[str, Any]  # key -> value, in the sweep file's order of keys
    seed: int  # the planner's seed (planner.seed of the scenario)
    scenario: dict[str, Any]


@dataclass(frozen=True)
class Sweep:
    """A validated sweep file."""

    name: str
    description: str
    mode: str
    check: bool
    exhaustive: bool
    kind: str  # "grid" | "random" | "tasks"
    keys: tuple[str, ...]  # what varies, in order
    axes: tuple[tuple[Any, ...], ...]  # grid: the values of each key
    base: dict[str, Any]  # the base scenario with `set` applied (and legs dropped: auto mode)
    random: RandomSpec | None
    rows: tuple[dict[str, Any], ...]  # explicit tasks: key -> value
    source: str
    text: str
    states: tuple[str, ...]
    reference_energy: float | None

    @property
    def count(self) -> int:
        if self.kind == "grid":
            return int(np.prod([len(a) for a in self.axes]))
        return self.random.count if self.kind == "random" else len(self.rows)

    @property
    def digest(self) -> str:
        """SHA-256 of everything that decides the tasks (what `--resume` must find again)."""
        doc = {
            "mode": self.mode,
            "check": self.check,
            "exhaustive": self.exhaustive,
            "kind": self.kind,
            "keys": self.keys,
            "axes": self.axes,
            "base": self.base,
            "random": self.random.model_dump() if self.random else None,
            "rows": self.rows,
        }
        text = json.dumps(doc, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()

    def tasks(self, skip: set[int] | frozenset[int] = frozenset()) -> Iterator[SweepTask]:
        """The tasks, in index order, leaving out the indices in `skip`."""
        if self.kind == "grid":
            values: Iterator[tuple[Any, ...]] = itertools.product(*self.axes)
        elif self.kind == "tasks":
            values = (tuple(row[k] for k in self.keys) for row in self.rows)
        else:
            values = (self._draw(k) for k in range(self.random.count))
        for index, vals in enumerate(values):
            if index in skip:
                continue
            inputs = dict(zip(self.keys, vals, strict=True))
            scenario = copy.deepcopy(self.base)
            seed = self._seed(index)
            if self.kind == "random":
                scenario.setdefault("planner", {})["seed"] = seed
            for key, value in inputs.items():
                assign(scenario, key, value, self.states)
            seed = int(scenario.get("planner", {}).get("seed", 0))
            yield SweepTask(index, inputs, seed, scenario)

    def _draw(self, k: int) -> tuple[float, ...]:
        rng = np.random.default_rng(self._sequence(k))
        return tuple(float(rng.uniform(lo, hi)) for lo, hi in self.random.ranges.values())

    def _sequence(self, k: int) -> np.random.SeedSequence:
        return np.random.SeedSequence(self.random.seed, spawn_key=(k,))

    def _seed(self, k: int) -> int:
        if self.kind != "random":
            return 0
        return int(self._sequence(k).generate_state(1, np.uint64)[0] >> np.uint64(1))


# ------------------------------------------------------------------------------------------
# Loading
# ------------------------------------------------------------------------------------------


def load_sweep(source: str | Path | Mapping[str, Any], name: str | None = None) -> Sweep:
    """Read and validate a sweep file.

    Parameters
    ----------
    source : str, Path or Mapping
        What `load_scenario` takes: a path to the sweep file (TOML; a base scenario path in it
        is relative to its directory); TOML text (a string with a newline, or an "=" that
        names no file: `tomlread.is_toml_text`); or a plain `dict` of the same structure
        (numpy values and arrays as Python's: a grid axis may be ``np.arange(...)``). A base
        scenario path in text or a dict is relative to the current directory.
    name : str, optional
        How messages refer to the source (default: the path, "<text>" or "<dict>").

    Returns
    -------
    Sweep
        The validated sweep; `Sweep.tasks()` yields its tasks.

    Raises
    ------
    InputError
        Naming every problem, one line each: `file: field.path: message (got value)`.
    TypeError
        `source` is none of these.
    """
    raw, text, where, folder = read_source(source, name, "sweep")
    if text is None:  # a dict: recorded as the TOML file it stands for
        try:
            text = tomlwrite.dumps(raw)
        except (TypeError, ValueError) as exc:
            raise InputError(f"cannot be written as TOML: {exc}", where) from None
    folder = folder or Path()
    if non_finite := reject_non_finite(raw):
        raise InputError(non_finite, where)
    try:
        spec = SweepFile.model_validate(raw)
    except ValidationError as exc:
        raise InputError(validation_problems(exc, root=SweepFile), where) from None
    try:
        return _resolve(spec, folder, where, text)
    except InputError as exc:
        raise exc.with_source(where) from None


def _base(spec: SweepFile, folder: Path) -> tuple[dict[str, Any], str]:
    given = [spec.sweep.scenario is not None, spec.scenario is not None]
    if sum(given) != 1:
        raise InputError(
            [Problem("sweep.scenario", "give a base scenario: a path here or a [scenario] table")]
            if not any(given)
            else [Problem("sweep.scenario", "give a path or a [scenario] table, not both")]
        )
    if spec.scenario is not None:
        return copy.deepcopy(spec.scenario), "scenario"
    path = folder / spec.sweep.scenario
    try:
        text = read_scenario_text(path)
        return _urdf_from(parse_toml(text, str(path)), path.parent), spec.sweep.scenario
    except InputError as exc:  # say which file: the path is relative to the sweep file
        given, read = spec.sweep.scenario, os.path.normpath(path)
        where = given if read == os.path.normpath(given) else f"{given} ({read})"
        problems = [Problem("sweep.scenario", f"{where}: {p.message}") for p in exc.problems]
        raise InputError(problems) from None


def _urdf_from(raw: dict[str, Any], folder: Path) -> dict[str, Any]:
    """A base scenario's relative URDF path made relative to its file's `folder`, as when the
    file is planned alone (its tasks are dicts: read from the working directory otherwise)."""
    model = raw.get("model")
    if (
        isinstance(model, dict)
        and model.get("kind") == "urdf"
        and isinstance(model.get("path"), str)
    ):
        model["path"] = str((folder / Path(model["path"]).expanduser()).absolute())
    return raw


def _resolve(spec: SweepFile, folder: Path, source: str, text: str) -> Sweep:
    s = spec.sweep
    base, where = _base(spec, folder)
    if s.mode in ("auto", "compare"):
        base.pop("legs", None)
        base.setdefault("decompose", {})
    try:
        task = load_scenario(copy.deepcopy(base), name=where)
    except InputError as exc:
        problems = [_under(where, p) for p in exc.problems if p.path != "legs"]
        if s.mode == "legs" and "legs" not in base:
            needs = "legs mode needs a base scenario with [[legs]] (or mode = auto)"
            problems.append(Problem("sweep.mode", needs))
        raise InputError(problems or [_under(where, p) for p in exc.problems]) from None
    states = tuple(task.system.states)
    problems: list[Problem] = []
    for key, value in s.set.items():
        field = f'sweep.set."{key}"'
        value = value_of(key, value, field, problems)
        check_value(base, key, value, states, field, problems)
        if not problems:
            try:
                assign(base, key, value, states)
            except ValueError as exc:
                problems.append(Problem(field, str(exc)))
    if problems:
        raise InputError(problems)
    if s.set:
        check_scenario(base, field="sweep.set", problems=problems)
    kinds = [k for k in ("grid", "random", "task") if getattr(s, k) is not None]
    if len(kinds) != 1:
        what = "one of" if not kinds else "only one of"
        tables = "[sweep.grid], [sweep.random], [[sweep.task]]"
        problems.append(Problem("sweep", f"give {what} {tables}"))
    if problems:
        raise InputError(problems)
    axes: list[tuple[Any, ...]] = []
    rows: list[dict[str, Any]] = []
    keys: tuple[str, ...] = ()
    random = s.random
    if s.grid is not None:
        keys = tuple(s.grid)
        for key, axis in s.grid.items():
            field = f'sweep.grid."{key}"'
            values = axis_values(key, axis, field, problems)
            axes.append(values)
            if key_problem(base, key, states, field, problems):
                continue
            for i, value in enumerate(values[:MAX_CHECKED]):
                check_value(base, key, value, states, f"{field}[{i}]", problems)
        total = int(np.prod([max(1, len(a)) for a in axes]))
        if total > MAX_TASKS:
            problems.append(Problem("sweep.grid", f"{total} tasks (at most {MAX_TASKS})"))
    elif random is not None:
        keys = tuple(random.ranges)
        ranges = {}
        for key, pair in random.ranges.items():
            field = f'sweep.random.ranges."{key}"'
            if valid_key(key) and not is_coordinate(key):
                problems.append(Problem(field, "random ranges are for coordinates (goal.q1, ...)"))
            bounds = [number(v, f"{field}[{i}]", problems) for i, v in enumerate(pair)]
            if len(pair) != 2:
                problems.append(Problem(field, f"needs [low, high] (got {len(pair)} values)"))
            elif None not in bounds and not bounds[0] < bounds[1]:
                problems.append(Problem(field, f"low must be below high (got {pair})"))
            elif None not in bounds and not key_problem(base, key, states, field, problems):
                for i, b in enumerate(bounds):
                    check_value(base, key, b, states, f"{field}[{i}]", problems)
            ranges[key] = bounds
        if not problems:
            random = RandomSpec(count=random.count, seed=random.seed, ranges=ranges)
    else:
        keys = tuple(dict.fromkeys(k for row in s.task for k in row))
        for i, row in enumerate(s.task):
            missing = [k for k in keys if k not in row]
            if missing:
                setters = ", ".join(  # the first task that sets each: where the key came from
                    f"{k} (set by sweep.task[{next(j for j, r in enumerate(s.task) if k in r)}])"
                    for k in missing
                )
                why = f"misses {setters}: every [[sweep.task]] sets the same keys"
                problems.append(Problem(f"sweep.task[{i}]", why))
                continue
            values = {k: value_of(k, v, f'sweep.task[{i}]."{k}"', problems) for k, v in row.items()}
            rows.append(values)
            if i < MAX_CHECKED and not problems:
                check_values(base, values, states, f"sweep.task[{i}]", problems)
    if problems:
        raise InputError(problems)
    reference = (base.get("reference") or {}).get("energy")
    return Sweep(
        s.name, s.description, s.mode, s.check, s.exhaustive, kinds[0].replace("task", "tasks"),
        keys, tuple(axes), base, random, tuple(rows), source, text, states,
        float(reference) if isinstance(reference, int | float) else None,
    )  # fmt: skip


def _under(where: str, p: Problem) -> Problem:
    """A problem of the base scenario: under [scenario], or in the file sweep.scenario names."""
    if where == "scenario":
        return Problem(f"scenario.{p.path}" if p.path else "scenario", p.message)
    return Problem("sweep.scenario", f"{where}: {p.path}: {p.message}" if p.path else p.message)
