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
"""

from __future__ import annotations

import hashlib
import re
import tomllib
from pathlib import Path
from typing import Any

from .. import tomlwrite

__all__ = ["FALLBACK_NAME", "model_files", "with_model_path"]

FALLBACK_NAME = "robot.urdf"  # when the file's own name is taken or not a plain name
_PLAIN = re.compile(r"^[A-Za-z0-9_+-][A-Za-z0-9_.+-]{0,99}$")
_PATH = re.compile(r"""\bpath(\s*=\s*)("(?:[^"\\\n]|\\.)*"|'[^'\n]*')""")


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
    name = Path(source).name
    if not _PLAIN.match(name) or name in taken or name == "scenario.toml":
        name = FALLBACK_NAME
    text = with_model_path(task.text, name)
    entry = {
        "file": name,
        "sha256": hashlib.sha256(robot.text.encode("utf-8")).hexdigest(),
        "source": source,
    }
    return text, {name: robot.text}, entry


def with_model_path(text: str, path: str) -> str:
    """The scenario TOML `text` with `[model] path` set to `path`, nothing else changed.

    The string after a `path =` is replaced where the result parses to the same scenario
    but for that value; when no occurrence does, the parsed scenario is written out again.
    """
    original = tomllib.loads(text)
    wanted = {**original, "model": {**original["model"], "path": path}}
    literal = '"' + path.replace("\\", "\\\\").replace('"', '\\"') + '"'
    for match in _PATH.finditer(text):
        candidate = text[: match.start(2)] + literal + text[match.end(2) :]
        try:
            if tomllib.loads(candidate) == wanted:
                return candidate
        except tomllib.TOMLDecodeError:
            continue
    return tomlwrite.dumps(wanted)
