"""`stratplan models`: the preset models, or one model described (a preset by name, a
scenario file's model or a URDF file's), as a table or as JSON."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from . import render, render_tables
from .options import Json, name_or_file


def models(
    target: Annotated[
        str | None,
        typer.Argument(
            metavar="NAME|FILE",
            help="A preset model's name, a scenario file or a URDF file: describe it.",
            parser=name_or_file,
        ),
    ] = None,
    json_output: Json = False,
) -> None:
    """List the preset models, or describe one: a preset by NAME, or a scenario FILE's model.

    Described: coordinates, inputs and every stratum with its locked coordinates, active
    inputs, dimension and the end-point evaluator `auto` will use on it. A URDF file is
    described as `[model] kind = "urdf"` would read it (joints, limits, default strata).
    With --json: the same as JSON (the presets: a list). Exits 0, or 2 when the argument is
    neither a preset nor a scenario or URDF file.
    """
    if target is None:  # the static table: listing presets builds no sympy model
        from ..models.presets import PRESET_TABLE  # start-up speed

        if json_output:
            render.print_json([
                {"model": name, "coordinates": list(info.states), "inputs": list(info.inputs),
                 "strata": list(info.strata), "description": info.description}
                for name, info in PRESET_TABLE.items()
            ])  # fmt: skip
            return
        render_tables.presets_table(PRESET_TABLE)
        return
    if json_output:
        _model_json(target)
        return
    from .. import api  # start-up speed
    from ..api.inspection import preset_or_scenario, scenario_model
    from ..errors import InputError
    from ..task import model_name

    try:
        found = preset_or_scenario(target)
    except InputError as exc:  # the model itself may be fine: described, then the problems
        model_ok = not any(p.path == "model" or p.path.startswith("model.") for p in exc.problems)
        system = scenario_model(target) if model_ok and Path(target).is_file() else None
        if system is not None:
            name = model_name(system.spec)
            render_tables.model(name, system, api.strata_table(system), of=Path(target).name)
        with render.reported():
            raise
    with render.reported():
        name, system, of = _described(found, target)
        render_tables.model(name, system, api.strata_table(system), of=of)
    if hasattr(found, "settings") and found.settings.evaluator != "auto":
        render.say(f"this scenario asks for the {found.settings.evaluator} evaluator")


def _described(found, target: str) -> tuple:
    """(name, model, what it is of: None for a preset) of what `preset_or_scenario` found:
    a preset's name, a URDF file's model (a System) or a scenario's task."""
    if isinstance(found, str):
        from ..models.presets import preset  # start-up speed

        return found, preset(found), None
    if not hasattr(found, "scenario"):  # a URDF file's model
        return "urdf", found, Path(target).name
    return found.model_name, found.system, found.scenario.name


def _model_json(target: str) -> None:
    """`models TARGET --json`: the model's coordinates, inputs and strata (`strata_table`);
    bad input as for the table (one line each, exit 2)."""
    from .. import api  # start-up speed
    from ..api.inspection import preset_or_scenario

    with render.reported():
        name, system, _ = _described(preset_or_scenario(target), target)
        render.print_json(
            {
                "model": name,
                "of": target,
                "description": system.description,
                "coordinates": list(system.states),
                "inputs": list(system.inputs),
                "strata": api.strata_table(system),
                **api.urdf_facts(system),
            }
        )
