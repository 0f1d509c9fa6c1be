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
integers from lo to hi for an integer setting;
task k draws from ``SeedSequence(seed, spawn_key=(k,))`` and plans with a seed drawn from it),
or an explicit ``[[sweep.task]]`` table of ``key = value`` rows.

A key names a scenario value: ``start.NAME``, ``goal.NAME`` and ``legs[i].goal.NAME`` are
coordinates (NAME a coordinate of the model, e.g. ``q1`` or ``theta``; ``task.`` may be
written in front), anything else a dotted path into the scenario (``planner.tolerance``,
``decompose.max_length``). Problems are reported as the scenario's are: one line each,
naming the field (`stratcli.errors.InputError`, exit 2); all of them at once, the schema's
beside those of the values (`tables`), which leave out what the schema refused (`_usable`).
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import AfterValidator, BaseModel, Field, ValidationError

from .. import tomlwrite
from ..errors import InputError, Problem
from ..models.specs import STRICT
from ..scenario_keys import assign, changes_task
from ..schema_problems import file_location, validation_problems
from ..settings import Bool, Int
from ..tomlread import (
    raise_non_finite,
    read_source,
    reject_non_finite,
)
from .base import checked_base, tasks_as_tables
from .keys import MAX_TASKS
from .tables import grid_axes, random_ranges, task_rows

MODES = ("legs", "auto", "compare")
# (not starting with ".": ".." was a name, its default output sweeps/..)
Name = Annotated[str, Field(pattern=r"^[A-Za-z0-9_-][A-Za-z0-9_.-]*$", max_length=100)]


def _start_stop_count(value: list[Any]) -> list[Any]:
    if len(value) != 3:  # (pydantic's "at least 3 entries" read as "3 or more")
        raise ValueError(f"must be [start, stop, count]: 3 values, not {len(value)}")
    return value


class Linspace(BaseModel):
    model_config = STRICT
    linspace: Annotated[list[Any], AfterValidator(_start_stop_count)]


class RandomSpec(BaseModel):
    model_config = STRICT
    count: Annotated[Int, Field(ge=1, le=MAX_TASKS)]
    seed: Annotated[Int, Field(ge=0, lt=2**63)] = 0
    ranges: dict[str, list[Any]] = Field(min_length=1)


class SweepSpec(BaseModel):
    model_config = STRICT
    name: Name
    description: str = Field("", max_length=10_000)
    scenario: str | None = Field(None, max_length=4096)
    mode: Literal["legs", "auto", "compare"] = "legs"
    check: Bool = True  # controllability check of each task (as `stratplan plan`)
    exhaustive: Bool = False  # compare mode: every candidate searched to its minimum
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
    base_text: str | None = None  # the base scenario file's text as given (None: inline)
    robot_text: str | None = None  # a URDF base's robot as loaded (digest, and the copy)

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
            "base": _robot_content(self.base, self.robot_text),
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
            if any(changes_task(key) for key in inputs):  # another task: not the paper's
                scenario.pop("reference", None)
            seed = int(scenario.get("planner", {}).get("seed", 0))
            yield SweepTask(index, inputs, seed, scenario)

    def out_dir(self, out: str | Path | None = None) -> Path:
        """The directory the sweep writes: `out`, else sweeps/NAME."""
        return Path(out) if out is not None else Path("sweeps") / self.name

    def _draw(self, k: int) -> tuple[float | int, ...]:
        """Task k's values: uniform on [lo, hi], integers from lo to hi for an integer
        setting (its bounds kept as integers by `tables.random_ranges`), in key order."""
        rng = np.random.default_rng(self._sequence(k))
        return tuple(
            int(rng.integers(lo, hi, endpoint=True))
            if isinstance(lo, int) and isinstance(hi, int)
            else float(rng.uniform(lo, hi))
            for lo, hi in self.random.ranges.values()
        )

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
        (numpy values and arrays as Python's: a grid axis may be ``np.arange(...)``; the base
        scenario a `Task`, as ``"scenario"`` or ``sweep.scenario``). A base scenario path in
        text or a dict is relative to the current directory.
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
    if isinstance(source, Mapping):
        source = tasks_as_tables(source)
    _not_a_summary(source)
    raw, text, where, folder = read_source(source, name, "sweep")
    if text is None:  # a dict: recorded as the TOML file it stands for
        try:
            text = tomlwrite.dumps(raw)
        except (TypeError, ValueError) as exc:
            raise InputError(f"cannot be written as TOML: {exc}", where) from None
    if non_finite := reject_non_finite(raw):  # with every other problem of the file
        raise_non_finite(raw, non_finite, lambda r: _load(r, text, where, folder), where)
    return _load(raw, text, where, folder)


def _load(raw: dict[str, Any], text: str, where: str, folder: Path | None) -> Sweep:
    """`load_sweep` of the file's tables `raw` (finite)."""
    problems: list[Problem] = []
    try:
        spec, pruned = SweepFile.model_validate(raw), set()
    except ValidationError as exc:  # reported; the values it did not refuse are checked too
        problems = validation_problems(exc, root=SweepFile)
        spec, pruned = _usable(raw, exc)
    sweep = None
    if spec is not None:
        given = [k for k in ("grid", "random", "task") if k in raw["sweep"]]
        sweep = _resolve(spec, given, pruned, folder or Path(), where, text, problems)
    if problems or sweep is None:
        raise InputError(problems, where)
    return sweep


# A required value the schema refused is replaced by one that nothing else depends on
_PLACEHOLDERS = {("sweep", "name"): "sweep", ("sweep", "random", "count"): 1}


def _usable(raw: dict[str, Any], exc: ValidationError) -> tuple[SweepFile | None, set[tuple]]:
    """The file without the values the schema refused (one axis, range or task; else the
    whole key of [sweep]), validated; and where those values were (None: [sweep] is not a
    table, nothing else can be checked)."""
    usable, pruned = copy.deepcopy(raw), set()
    for _ in range(5):  # leaving a value out may empty a table that must not be
        for err in exc.errors():
            loc = file_location(tuple(err["loc"]))
            cut = loc[: _depth(loc)]
            if err["type"] == "missing" and cut == loc and cut not in _PLACEHOLDERS:
                cut = cut[:-1]  # the table that misses a key
            if cut in ((), ("sweep",)):
                return None, pruned
            pruned.add(cut)
            node = usable
            for part in cut[:-1]:
                node = node.get(part) if isinstance(node, dict) else None
            if cut in _PLACEHOLDERS and isinstance(node, dict):
                node[cut[-1]] = _PLACEHOLDERS[cut]
            elif isinstance(node, list) and isinstance(cut[-1], int) and cut[-1] < len(node):
                node[cut[-1]] = {}  # a task: the others keep their index
            elif isinstance(node, dict):
                node.pop(cut[-1], None)
        try:
            return SweepFile.model_validate(usable), pruned
        except ValidationError as again:
            exc = again
    return None, pruned


def _depth(loc: tuple) -> int:
    """How much of a refused value's location is left out: a whole key of [sweep], but one
    axis of [sweep.grid], one range of [sweep.random] or one [[sweep.task]]."""
    if loc[:1] != ("sweep",):
        return 1
    if loc[1:3] == ("random", "ranges"):
        return 4
    return 3 if loc[1:2] in (("grid",), ("random",), ("task",)) else 2


def _resolve(
    spec: SweepFile, given: list[str], pruned: set[tuple], folder: Path, source: str, text: str,
    problems: list[Problem],
) -> Sweep | None:  # fmt: skip
    """The sweep `spec` describes, or None with its problems added to `problems`; `given`
    names the tables of tasks the file has (any the schema refused too), `pruned` where the
    schema refused a value (`_usable`)."""
    s = spec.sweep
    base = checked_base(spec, pruned, folder, problems)
    if len(given) != 1:
        what = "one of" if not given else "only one of"
        tables = "[sweep.grid], [sweep.random], [[sweep.task]]"
        problems.append(Problem("sweep", f"give {what} {tables}"))
    axes: list[tuple[Any, ...]] = []
    rows: list[dict[str, Any]] = []
    keys: tuple[str, ...] = ()
    random = s.random
    if s.grid is not None:
        keys, axes = tuple(s.grid), grid_axes(s.grid, base)
    if random is not None:
        keys, ranges = tuple(random.ranges), random_ranges(random.ranges, base)
    if s.task is not None:
        keys, rows = task_rows(s.task, base)
    if problems:
        return None
    if random is not None:
        random = RandomSpec(count=random.count, seed=random.seed, ranges=ranges)
    reference = (base.scenario.get("reference") or {}).get("energy")
    if any(changes_task(key) for key in (*keys, *s.set)):  # the paper's, for another task
        reference = None  # (each task drops it: energy_hist.png took ratios to it)
    return Sweep(
        s.name, s.description, s.mode, s.check, s.exhaustive, given[0].replace("task", "tasks"),
        keys, tuple(axes), base.scenario, random, tuple(rows), source, text, base.states,
        float(reference) if isinstance(reference, int | float) else None, base.text,
        _robot_text(base.scenario),
    )  # fmt: skip


def _not_a_summary(source: Any) -> None:
    """A sweep directory's sweep.json (its summary) given for the sweep file: one line, not
    a line per summary key (`sweep: required field is missing`, `schema: unknown key` ...)."""
    from ..records.sweepdir import FILE_TEXT, SUMMARY, is_sweep_dir

    if isinstance(source, Path) or (isinstance(source, str) and "\n" not in source):
        path = Path(source)
        if path.name == SUMMARY and is_sweep_dir(path.parent):
            raise InputError(
                f"the summary of the sweep in {path.parent}, not a sweep file: the sweep file "
                f"is {path.parent / FILE_TEXT} beside it",
                str(path),
            )


def _robot_text(base: dict[str, Any]) -> str | None:
    """A URDF base's robot file, read once with the sweep (None: another model, or
    unreadable): its digest and the sweep directory's copy are of the same text."""
    model = base.get("model")
    if not (isinstance(model, dict) and model.get("kind") == "urdf"):
        return None
    try:
        return Path(model["path"]).read_text(encoding="utf-8")
    except (OSError, TypeError, ValueError):
        return None


def _robot_content(base: dict[str, Any], text: str | None) -> dict[str, Any]:
    """`base` with a URDF model's path replaced by its robot's SHA-256: the robot decides the
    tasks, not where its file lies (a sweep directory's copy names its own; `sweep_files`)."""
    if text is None:
        return base
    sha256 = hashlib.sha256(text.encode("utf-8")).hexdigest()
    return {**base, "model": {**base["model"], "path": f"sha256:{sha256}"}}
