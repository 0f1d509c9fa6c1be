"""What a scenario with a `[model] kind = "urdf"` needs before validation: the URDF's path
made absolute (relative to the scenario file) and configurations given by joint name turned
into lists in coordinate order (`spatial.configuration_list`)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

from pydantic import TypeAdapter, ValidationError

from ..errors import InputError, Problem
from .specs import UrdfModel, build_system
from .system import System

__all__ = ["prepare_urdf"]


def prepare_urdf(raw: dict[str, Any], base_dir: Path | None) -> tuple[dict, System | None]:
    """(raw with the URDF path absolute and named configurations as lists, the system built
    from it), or (raw, None) when the [model] table is invalid (validation reports it)."""
    from .spatial import configuration_list

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
