"""Inspection use cases: controllability checks and model descriptions."""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..arguments import checked, flag, integer, source
from ..errors import InputError, NotControllableError, Problem
from ..frozen_json import HoldsDocument
from ..liealgebra import MAX_DEGREE
from ..models.numbers import parse_number
from ..models.presets import PRESETS, meant_preset, preset
from ..models.system import System
from ..scenario import Task, load_scenario
from ..tomlread import is_toml_text, is_xml_text
from ..wording import counted
from .check import MAX_SAMPLES, check_document


@dataclass(frozen=True)
class CheckReport(HoldsDocument):
    """A controllability check (paper eqs. 2 and 4) of a preset model or a scenario.

    Attributes
    ----------
    document : dict
        What `stratplan check --json` prints (read-only): each stratum's rank and smallest
        singular value, each leg's verdict, `problems` and `warnings`.
    title : str
        "preset <name>", "URDF <file>" or "<scenario> (<model> model)".
    seconds : float
        How long the check took.
    controllable : bool
        Whether it passed (the command's exit code 0).
    problems : list of str
        One sentence per failed check.
    """

    document: dict[str, Any]  # what `stratplan check --json` prints (read-only: `frozen_json`)
    title: str  # "preset <name>", "URDF <file>" or "<scenario> (<model> model)"
    seconds: float

    def __hash__(self) -> int:  # (the document is a dict: equal reports share their title)
        return hash(self.title)

    @property
    def controllable(self) -> bool:
        """Whether the check passed (exit code 0): every leg's stratum spans what it steers,
        or (without legs) every stratum is strongly controllable (eq. 4)."""
        return bool(self.document["controllable"])

    def __repr__(self) -> str:  # the dataclass's prints the whole document (kB)
        strata = ", ".join(s["stratum"] for s in self.document.get("strata", []))
        problems = counted(len(self.document.get("problems", [])), "problem")
        verdict = "controllable" if self.controllable else f"NOT controllable ({problems})"
        warnings = len(self.document.get("warnings", []))
        warned = f", {counted(warnings, 'warning')}" if warnings else ""
        return (
            f"CheckReport({self.title}: {verdict}{warned}; strata {strata}, {self.seconds:.2g} s)"
        )

    @property
    def problems(self) -> list[str]:
        """One sentence per failed check (empty when `controllable`)."""
        return list(self.document["problems"])


# ------------------------------------------------------------------------------------------
# Controllability
# ------------------------------------------------------------------------------------------


def check_strata(task: Task) -> list[str]:
    """The strata a scenario's check covers: its legs', its [decompose] table's, or all."""
    if task.legs:
        return list(dict.fromkeys(leg.stratum for leg in task.legs))
    if task.scenario.decompose and task.scenario.decompose.strata:
        return list(task.scenario.decompose.strata)
    return list(task.system.strata)


def controllability_first(
    task: Task,
    degree: int = 2,
    samples: int = 100,
    warn: Callable[[str], None] | None = None,
) -> float:
    """The check planning runs first; returns its seconds or raises NotControllableError.

    Each leg's stratum must span what the leg steers (or, in auto mode, the candidate strata
    together must reach every direction); Lie legs raise the bracket degree to theirs. Each
    warning of the check (a leg that may be ill-conditioned) is passed to `warn`.
    """
    clock = time.perf_counter()
    lie = [(leg.lie or task.settings.lie).degree for leg in task.legs if leg.method == "lie"]
    doc = check_document(
        task.system,
        check_strata(task),
        task.start,
        samples=samples,
        degree=max([degree, *lie]),
        legs=task.legs or None,
    )
    if doc["model_problems"]:
        raise InputError([Problem("model.fields", p) for p in doc["model_problems"]], task.source)
    if doc["problems"]:
        raise NotControllableError(doc["problems"], task.source)
    for warning in doc["warnings"] if warn is not None else ():
        warn(warning)
    return time.perf_counter() - clock


@checked(
    target=source("scenario", Task),
    samples=integer(0, MAX_SAMPLES),
    degree=integer(1, MAX_DEGREE),
    seed=integer(0, 2**63 - 1),
    all_strata=flag,
)
def check_controllability(
    target: str | Path | Mapping[str, Any] | Task,
    at: str | Sequence[float] | None = None,
    samples: int = 100,
    degree: int = 2,
    seed: int = 0,
    all_strata: bool = False,
) -> CheckReport:
    """Controllability of every stratum (paper eq. 4) and of the strata together (eq. 2).

    Parameters
    ----------
    target : str, Path, Mapping or Task
        A preset model name, or a scenario: a loaded one, or what `load_scenario` takes.
    at : str or sequence of float, optional
        The configuration, e.g. ``"0, pi/3, 0, 0"`` (default: the scenario start, or zeros
        for a preset).
    samples : int
        Sampled configurations checked besides `at` (at most `MAX_SAMPLES`, 100 000: each
        costs about 1 kB of memory and 13 µs a stratum).
    degree : int
        Lie bracket degree (1-3).
    seed : int
        Seed of the sampled configurations.
    all_strata : bool
        For a scenario, every stratum of its model (default: those its legs use, or its
        [decompose] table's candidates).

    Returns
    -------
    CheckReport
        The check document (`.controllable`, `.problems`), a title and the time taken.

    Raises
    ------
    InputError
        A bad scenario or `at`, or `samples`, `degree` or `seed` out of range (named).
    TypeError
        An argument of the wrong type, named.
    """
    task = preset_or_scenario(target)
    if isinstance(task, str):
        system, legs, title, task = preset(task), None, f"preset {task}", None
        strata, q = list(system.strata), [0.0] * system.n
    elif isinstance(task, System):  # a URDF file alone: its model at zero joints
        system, legs, title, task = task, None, f"URDF {Path(target).name}", None
        strata, q = list(system.strata), [0.0] * system.n
    else:
        system, legs, q = task.system, task.legs or None, task.start
        strata = list(system.strata) if all_strata else check_strata(task)
        title = f"{task.scenario.name} ({task.model_name} model)"
    if at is not None:
        q = configuration(system, at)
    clock = time.perf_counter()
    doc = check_document(system, strata, q, samples=samples, degree=degree, seed=seed, legs=legs)
    seconds = time.perf_counter() - clock
    doc["target"] = task.source if task is not None else str(target)
    if task is not None:  # a URDF scenario's start, vias or goal outside the URDF's limits
        from ..urdf_limits import outside_limits

        doc["warnings"] += outside_limits(task)
        doc["warnings"] += limit_warnings(task)
    return CheckReport(doc, title, seconds)


def limit_warnings(task: Task) -> list[str]:
    """What `plan`, `compare-sequences` and `check` warn of before planning: joint limits
    (the [constraints] table's, a URDF's) and start, via or goal angles past a full turn
    (degrees written as numbers?) on a planar or URDF robot; a table's joint limits wider
    than the URDF's own.

    Parameters
    ----------
    task : Task
        A loaded scenario.

    Returns
    -------
    list of str
        One sentence per pair of such limits and per such configuration; empty without.
    """
    from ..limit_units import degree_like_configurations, degree_like_limits
    from ..urdf_limits import wider_than_urdf

    return (
        degree_like_limits(task.constraints, task.system)
        + degree_like_configurations(task)
        + wider_than_urdf(task)
    )


def preset_or_scenario(target: str | Path | Mapping[str, Any] | Task) -> str | Task | System:
    """A preset model's name, a loaded scenario, or a URDF file's model (what `check` and
    `models` take).

    Parameters
    ----------
    target : str, Path, Mapping or Task
        A preset name (a file of that name wins), a URDF file (XML), or a scenario: a loaded
        one, or what `load_scenario` takes.

    Returns
    -------
    str, Task or System
        The preset's name, the scenario, or the URDF's model (its default strata).

    Raises
    ------
    InputError
        "no such file" when `target` names a missing .toml or .urdf file or a path, "not a
        preset (did you mean ...)" for any other name that is no preset and no file; a
        scenario's own problems otherwise.
    """
    if isinstance(target, Task):
        return target
    text = isinstance(target, str) and is_toml_text(target)
    if isinstance(target, str | Path) and not text and not Path(target).exists():
        if str(target) in PRESETS:
            return str(target)
        raise InputError(_neither(str(target)), str(target))
    urdf = isinstance(target, str | Path) and not text and Path(target).suffix.lower() == ".urdf"
    if urdf or (isinstance(target, str | Path) and not text and _is_xml_file(Path(target))):
        return urdf_system(target)  # (an empty or broken .urdf: its own message, not a scenario's)
    return load_scenario(target)


def _neither(target: str) -> str:
    """Why a name is no model: a missing file (it looks like one), or no preset's name."""
    if Path(target).suffix.lower() in (".toml", ".urdf") or "/" in target or os.sep in target:
        return f"no such file (a preset is named {' or '.join(PRESETS)})"
    return f"not a preset ({meant_preset(target)}), a scenario file or a URDF file"


def scenario_model(path: str | Path) -> System | None:
    """The model of a scenario file's [model] table alone, or None where the file or the
    table is wrong too: `models FILE` describes it although the scenario's other tables have
    problems (the strata's names, say, are what its legs must use)."""
    import tomllib

    from pydantic import TypeAdapter

    from ..models.specs import ModelSpec, build_system

    try:
        model = tomllib.loads(Path(path).read_text(encoding="utf-8"))["model"]
        if isinstance(model, dict) and model.get("kind") == "urdf":  # its path as a scenario's
            from ..models.spatial_scenario import prepare_urdf

            return prepare_urdf({"model": model}, Path(path).parent)[1]
        return build_system(TypeAdapter(ModelSpec).validate_python(model))
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError, AttributeError):
        return None  # (tomllib's, pydantic's and stratplan's errors are ValueErrors)


def _is_xml_file(path: Path) -> bool:
    try:
        if not path.is_file():  # (opening a FIFO blocked `models` and `check` for good)
            return False
        with open(path, "rb") as fh:
            head = fh.read(1024)
    except OSError:
        return False  # (load_scenario names what is wrong with it)
    return is_xml_text(head.decode("utf-8", "replace"))


def urdf_system(path: str | Path) -> System:
    """The model of a URDF file alone, with the default strata (`models FILE.urdf`); an
    `InputError` naming the file for anything `[model] kind = "urdf"` would refuse."""
    from ..models.specs import UrdfModel, build_system  # Pinocchio only for URDF models

    resolved = str(Path(path).expanduser().resolve())
    spec = UrdfModel(kind="urdf", path=resolved)
    try:
        return build_system(spec)
    except InputError as exc:  # its field is the scenario's model.path: none here, nor the
        problems = [Problem("", p.message.removeprefix(f"{resolved}: ")) for p in exc.problems]
        raise InputError(problems, str(path)) from None  # file named twice


def configuration(system: System, at: str | Sequence[float], option: str = "at") -> list:
    """A configuration of `system` from text such as ``"(0, pi/3, 0, 0)"``; InputError naming
    `option` (the argument; the command line shows its flag) when it does not parse or has
    the wrong length."""
    try:
        if isinstance(at, str):
            values = [parse_number(x.strip()) for x in at.strip("()[] ").split(",")]
        else:
            values = [float(x) for x in at]
    except (ValueError, TypeError) as exc:
        raise InputError([Problem(option, f"not a configuration: {exc}")]) from None
    if len(values) != system.n:
        raise InputError(
            [
                Problem(
                    option,
                    f"needs {system.n} values ({', '.join(system.states)}), got {len(values)}",
                )
            ]
        )
    return values


# ------------------------------------------------------------------------------------------
# Models
# ------------------------------------------------------------------------------------------


def preset_models() -> dict[str, System]:
    """Every preset model by name.

    Returns
    -------
    dict
        Name → System.
    """
    return {name: preset(name) for name in PRESETS}


def strata_table(system: System) -> list[dict[str, Any]]:
    """Each stratum of `system`: locked coordinates, active inputs, dimension, evaluator.

    Parameters
    ----------
    system : System
        A model; its strata's numeric functions are generated.

    Returns
    -------
    list of dict
        stratum, locked, active, dimension and evaluator ("quadrature", "magnus" (a URDF
        model's attitude on SO(3)) or "ode", what `auto` uses on it).
    """
    rows = []
    for s in system.strata.values():
        cs = system.compiled(s)
        rows.append(
            {
                "stratum": s.name,
                "locked": [system.states[i] for i in s.locked],
                "active": [system.inputs[j] for j in s.active],
                "dimension": system.n - len(s.locked),
                "evaluator": _evaluator(cs),
            }
        )
    return rows


def urdf_facts(system: System) -> dict[str, Any]:
    """A URDF model's base, mass, joint limits and velocity limits (the numbers its
    description states, for scripts: `stratplan models FILE --json`); {} for other models.

    Parameters
    ----------
    system : System
        A model.

    Returns
    -------
    dict
        base (link name), mass (kg), joint_limits (joint -> [lower, upper], rad) and
        velocity_limits (joint -> rad/s, or None where the URDF gives none: Pinocchio's
        placeholder, or 0).
    """
    robot = getattr(system, "spatial", None)
    if robot is None:
        return {}
    names = robot.joint_names

    def rate(v: float) -> float | None:
        return float(v) if np.isfinite(v) and 0 < v < 1e6 else None

    return {
        "base": robot.base,
        "mass": float(robot.mass),
        "joint_limits": {
            j: [float(lo), float(hi)]
            for j, lo, hi in zip(names, robot.lower, robot.upper, strict=True)
        },
        "velocity_limits": {j: rate(v) for j, v in zip(names, robot.velocity, strict=True)},
    }


def _evaluator(cs) -> str:
    if getattr(cs, "endpoint", None) is not None:
        return "magnus"
    return "quadrature" if cs.supports_quadrature else "ode"
