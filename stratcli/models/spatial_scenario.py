"""What a scenario with a `[model] kind = "urdf"` needs before validation: the URDF's path
made absolute (relative to the scenario file) and configurations given by joint name turned
into lists in coordinate order (`spatial.configuration_list`)."""

from __future__ import annotations

import copy
import re
from difflib import get_close_matches
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import TypeAdapter, ValidationError

from .. import so3
from ..errors import InputError, Problem
from .specs import UrdfModel, build_system
from .system import System

__all__ = ["configuration_list", "named_paths", "prepare_urdf"]


def prepare_urdf(raw: dict[str, Any], base_dir: Path | None) -> tuple[dict, System | None]:
    """(raw with the URDF path absolute and named configurations as lists, the system built
    from it), or (raw, None) when the [model] table is invalid (validation reports it)."""
    raw = copy.deepcopy(raw)
    model = raw["model"]
    path = model.get("path")
    if isinstance(path, str) and path:
        full = Path(path).expanduser()
        if not full.is_absolute():
            full = (base_dir or Path.cwd()) / full
        model["path"] = str(full.resolve())
    try:
        spec = TypeAdapter(UrdfModel).validate_python(model)
    except ValidationError:
        return raw, None
    system = build_system(spec)
    task = raw.get("task")
    if isinstance(task, dict):
        for key in ("start", "goal"):
            if isinstance(task.get(key), dict):
                task[key] = configuration_list(task[key], system, f"task.{key}")
    for i, leg in enumerate(raw.get("legs") or []):
        if isinstance(leg, dict) and leg.get("method") == "lie":
            raise InputError(
                [
                    Problem(
                        f"legs[{i}].method",
                        'Lie-algebraic legs are not supported on URDF models yet (use "newton")',
                    )
                ]
            )
        if isinstance(leg, dict) and isinstance(leg.get("goal"), dict):
            leg["goal"] = configuration_list(leg["goal"], system, f"legs[{i}].goal")
    return raw, system


def _angle(value, where: str, problems: list[Problem]):
    from .numbers import parse_number

    if isinstance(value, str) and value.strip() == "*":
        return "*"
    try:
        return parse_number(value)
    except (ValueError, TypeError) as exc:
        problems.append(Problem(where, f"{exc} (got {value!r})"))
        return 0.0


def configuration_list(table: dict, system: System, where: str) -> list:
    """A configuration given by name (`{j1 = 0.3, ..., attitude = [rx, ry, rz]}` or with
    `rpy = [roll, pitch, yaw]`) as the list in coordinate order; raises `InputError`.

    The attitude is a rotation vector (rad, world frame) or URDF roll-pitch-yaw
    (`Rz(yaw) Ry(pitch) Rx(roll)`); `"*"` leaves a coordinate (or the whole attitude) free.
    """
    problems: list[Problem] = []
    joints = system.spatial.joint_names
    allowed = (*joints, "attitude", "rpy")
    unknown = [key for key in table if key not in allowed]
    missing = [j for j in joints if j not in table]
    # a misspelt joint: the missing joint it is closest to (then not reported missing too)
    meant = {k: close[0] for k in unknown if (close := get_close_matches(k, missing, n=1))}
    if unknown:
        names = ", ".join(f"{k} (did you mean {meant[k]}?)" if k in meant else k for k in unknown)
        problems.append(Problem(where, f"unknown names {names} (allowed: {', '.join(allowed)})"))
    missing = [j for j in missing if j not in meant.values()]
    if missing:
        problems.append(Problem(where, f'missing joints {", ".join(missing)} ("*" if free)'))
    if "attitude" in table and "rpy" in table:
        problems.append(Problem(where, "give either attitude or rpy, not both"))
    out = [table.get(j, 0.0) for j in joints]
    key = "rpy" if "rpy" in table else "attitude"
    value = table.get(key, [0.0, 0.0, 0.0])
    if isinstance(value, str) and value.strip() == "*":
        value = ["*"] * 3
    if not isinstance(value, list) or len(value) != 3:
        problems.append(Problem(f"{where}.{key}", f"needs 3 angles (rad), got {value!r}"))
        value = [0.0] * 3
    angles = [_angle(v, f"{where}.{key}[{i}]", problems) for i, v in enumerate(value)]
    for i, a in enumerate(angles):  # roll, pitch and yaw are within a turn: degrees?
        if key == "rpy" and a != "*" and abs(a) > 2 * np.pi:
            unit = value[i] if isinstance(value[i], str) else ""  # "400deg": in degrees already
            advice = (
                f'if degrees were meant, write "{a:g}deg"'
                if not any(u in unit.lower() for u in ("deg", "°"))
                else "give it within a turn"
            )
            problems.append(
                Problem(
                    f"{where}.rpy[{i}]",
                    f"{a:g} rad{f' ({value[i]})' if unit else ''} is past a full turn; "
                    f"{advice} (roll, pitch and yaw are within -2pi ... 2pi)",
                )
            )
    if problems:
        raise InputError(problems)
    if key == "rpy" and "*" not in angles:
        angles = so3.log(so3.rpy_to_matrix(angles)).tolist()
    elif key == "rpy" and any(a != "*" for a in angles):
        raise InputError([Problem(f"{where}.rpy", 'either all three angles or "*" for all')])
    return out + angles


def long_attitudes(task) -> list[str]:
    """A note for each start, via or goal attitude of a URDF task whose rotation vector is
    longer than π: it names the same rotation as a shorter one, which the plan starts from
    or reaches and result.json shows (a script comparing `end` with `goal` read 2π off)."""
    places = [("task.start", task.start, "the plan starts from (result.json's attitude.start")]
    places += [
        (f"legs[{i}].goal", leg.goal, f"leg {i + 1} reaches (result.json's legs[{i}].end")
        for i, leg in enumerate(task.legs[:-1])
    ]
    places += [("task.goal", task.goal, "the plan reaches (result.json's end")]
    out = []
    for where, phi, reached in attitudes(task.system, places):
        if not np.all(np.isfinite(phi)) or np.linalg.norm(phi) <= np.pi + 1e-9:
            continue
        short = so3.log(so3.exp(phi))
        shown = lambda v: "[" + ", ".join(f"{x:.4g}" for x in np.round(v, 12) + 0.0) + "]"  # noqa: E731
        degrees = (  # a component past a full turn: 45 for 45°?
            "; if degrees were meant, write ["
            + ", ".join(f'"{x:.4g}deg"' for x in np.round(phi, 12) + 0.0)
            + "]"
            if np.abs(phi).max() > 2 * np.pi
            else ""
        )
        out.append(
            f"{where}'s attitude {shown(phi)} turns by more than pi: it is the rotation "
            f"{shown(short)}, which {reached} shows that one){degrees}"
        )
    return out


def attitudes(system, places):
    """`(where, rotation vector, *rest)` of each `(where, q, *rest)` in `places` whose
    configuration `q` is given, for a URDF robot (its attitude after the joints); none for
    any other model (`long_attitudes`, `scenario_checks.attitude_problems`)."""
    robot = getattr(system, "spatial", None)
    if robot is None:
        return
    k = robot.n_joints
    for where, q, *rest in places:
        if q is not None:
            yield where, np.asarray(q, dtype=float)[k : k + 3], *rest


_INDEXED = re.compile(r"^(task\.(?:start|goal)|legs\[\d+\]\.goal)\[(\d+)\]$")


def named_paths(problems: list[Problem], given: dict[str, Any], system) -> list[Problem]:
    """`problems` of a URDF scenario with a configuration given by name named as written:
    `task.start.attitude[0]`, not `task.start[3]` (the list `configuration_list` made of it);
    an attitude "*" whose three components all fail the same way is one problem."""
    joints = system.spatial.joint_names
    out: list[Problem] = []
    for p in problems:
        found = _INDEXED.match(p.path)
        table = _configuration(given, found.group(1)) if found else None
        if not isinstance(table, dict):
            out.append(p)
            continue
        k = int(found.group(2))
        key = "rpy" if "rpy" in table else "attitude"
        name = joints[k] if k < len(joints) else f"{key}[{k - len(joints)}]"
        if k >= len(joints) and isinstance(table.get(key), str):
            name = key  # "*" for the whole attitude: one problem
        out.append(Problem(f"{found.group(1)}.{name}", p.message, p.given, p.flag_message))
    return list(dict.fromkeys(out))


def _configuration(given: dict[str, Any], path: str) -> Any:
    if path.startswith("task."):
        task = given.get("task")
        return task.get(path[5:]) if isinstance(task, dict) else None
    legs = given.get("legs")
    i = int(path[5 : path.index("]")])
    leg = legs[i] if isinstance(legs, list) and i < len(legs) else None
    return leg.get("goal") if isinstance(leg, dict) else None
