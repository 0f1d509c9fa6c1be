"""A URDF robot's record is self-contained: the URDF beside `scenario.toml`.

The scenario file names its URDF by a path relative to itself (`[model] path =
"../../robots/arm3.urdf"`), which means nothing inside a run directory. The record therefore
holds the URDF text that was planned (`SpatialRobot.text`, as read when the scenario was
loaded) under the file's own name, and its `scenario.toml` is the scenario as given with only
`[model] path` changed to that name, so that `stratplan plan <record>/scenario.toml` and
`stratcli.load_run` read the record's copy wherever the record is moved. The path is
replaced in the text itself (comments and layout kept) where that provably changes nothing
else; otherwise the scenario is written out again from its parsed form (`tomlwrite`).
`manifest.json` gets `urdf`: the file's name in the record, its sha256 and where it came from.

A sweep directory is made self-contained alike (`sweep_files`): beside its `sweep.toml` the
base scenario as `scenario.toml` (and its URDF), the copy's `sweep.scenario` naming it, so
that `stratplan sweep <dir>/sweep.toml` plans the same tasks wherever the directory is.
"""

from __future__ import annotations

import hashlib
import json
import re
import tomllib
from pathlib import Path
from typing import Any

from .. import tomlwrite
from ..errors import InputError
from ..scenario import nulls_as_free

__all__ = ["FALLBACK_NAME", "SCENARIO_FILE", "model_files", "sweep_files", "with_model_path"]

FALLBACK_NAME = "robot.urdf"  # when the file's own name is taken or not a plain name
_PLAIN = re.compile(r"^[A-Za-z0-9_+-][A-Za-z0-9_.+-]{0,99}$")
SCENARIO_FILE = "scenario.toml"  # a sweep directory's copy of its base scenario
_STRING = r"""(\s*=\s*)("(?:[^"\\\n]|\\.)*"|'[^'\n]*')"""


def model_files(task, taken: set[str]) -> tuple[str, dict[str, str], dict[str, Any]] | None:
    """For a URDF scenario: (the record's scenario.toml, {URDF file name: its text}, the
    manifest's `urdf` entry); None for every other model.

    Parameters
    ----------
    task : Task
        The planned scenario (its `text` and built model).
    taken : set of str
        The record's other file names, which the URDF's name must not replace.
    """
    robot = getattr(task.system, "spatial", None)
    if robot is None:
        return None
    source = str(getattr(task.scenario.model, "path", "") or robot.path)
    name = _urdf_name(source, {*taken, SCENARIO_FILE})
    text = with_model_path(task.text, name)
    entry = {
        "file": name,
        "sha256": hashlib.sha256(robot.text.encode("utf-8")).hexdigest(),
        "source": source,
    }
    return text, {name: robot.text}, entry


def with_model_path(text: str, path: str) -> str:
    """The scenario TOML `text` with `[model] path` set to `path`, nothing else changed."""
    return _with_string(text, ("model", "path"), path)


def _with_string(text: str, keys: tuple[str, ...], value: str) -> str:
    """The TOML `text` with the string at `keys` set to `value`, nothing else changed.

    The string after a `<last key> =` is replaced where the result parses to the same tables
    but for that value; when no occurrence does, the parsed tables are written out again.
    """
    original = tomllib.loads(text)
    wanted = _replaced(original, keys, value)
    literal = '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    for match in re.finditer(r"\b" + re.escape(keys[-1]) + _STRING, text):
        candidate = text[: match.start(2)] + literal + text[match.end(2) :]
        try:
            if tomllib.loads(candidate) == wanted:
                return candidate
        except tomllib.TOMLDecodeError:
            continue
    return tomlwrite.dumps(wanted)


def _replaced(tables: dict[str, Any], keys: tuple[str, ...], value: Any) -> dict[str, Any]:
    head, *rest = keys
    return {**tables, head: _replaced(tables[head], tuple(rest), value) if rest else value}


def _urdf_name(path: str, taken: set[str]) -> str:
    name = Path(path).name
    return name if _PLAIN.match(name) and name not in taken else FALLBACK_NAME


def sweep_files(sweep, taken: set[str]) -> dict[str, str]:
    """A sweep directory's copies: {file name: text} of its `sweep.toml` (the sweep file as
    given, TOML) and, where the sweep file names its base scenario by a path, of that
    scenario as `scenario.toml`, the copy's `sweep.scenario` naming it; a URDF base's robot
    under its own name (`taken`: the directory's other names), the copies naming it.

    Parameters
    ----------
    sweep : sweep.spec.Sweep
        The loaded sweep (its `text`, `base_text`, `robot_text` and `base`: a URDF path
        there is absolute).
    taken : set of str
        The sweep directory's other file names.
    """
    try:
        raw = tomllib.loads(sweep.text)
    except tomllib.TOMLDecodeError:  # a .json sweep file: the copy is its TOML
        raw = json.loads(sweep.text)
        text = tomlwrite.dumps(raw)
    else:
        text = sweep.text
    files: dict[str, str] = {}
    model = sweep.base.get("model") or {}
    urdf = model.get("path") if model.get("kind") == "urdf" else None
    if urdf is not None:
        name = _urdf_name(urdf, {*taken, SCENARIO_FILE, "sweep.toml"})
        if sweep.robot_text is None:  # (read when the sweep was loaded; it loaded)
            raise InputError(f"{urdf}: cannot read the base scenario's URDF")
        files[name] = sweep.robot_text
    inline = (raw.get("sweep") or {}).get("scenario") is None
    if not inline and sweep.base_text is not None:
        scenario = sweep.base_text
        try:
            tomllib.loads(scenario)
        except tomllib.TOMLDecodeError:  # a .json base (a record's resolved.json): as TOML
            scenario = tomlwrite.dumps(nulls_as_free(json.loads(scenario)))
        if urdf is not None:
            scenario = with_model_path(scenario, name)
        files[SCENARIO_FILE] = scenario
        text = _with_string(text, ("sweep", "scenario"), SCENARIO_FILE)
    elif inline and urdf is not None:
        text = _with_string(text, ("scenario", "model", "path"), name)
    return {"sweep.toml": text, **files}
