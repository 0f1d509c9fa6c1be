"""Reading a URDF far enough to validate it before Pinocchio builds the model (no `pin` needed).

`read_urdf` returns the robot's name, its links, its root link and its joints in file order,
and rejects, one line naming the joint, what the spatial models do not support yet:
prismatic, continuous, planar and floating joints and mimic joints. Fixed joints are
supported (Pinocchio merges the child's inertia into its parent). Every problem is an
`InputError` whose field is `model.path`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError, Problem

__all__ = ["UrdfJoint", "UrdfSummary", "read_urdf"]

MAX_BYTES = 5_000_000
SUPPORTED = ("revolute", "fixed")


@dataclass(frozen=True)
class UrdfJoint:
    name: str
    type: str
    parent: str
    child: str
    lower: float | None
    upper: float | None


@dataclass(frozen=True)
class UrdfSummary:
    name: str
    links: tuple[str, ...]
    root: str
    joints: tuple[UrdfJoint, ...]

    @property
    def revolute(self) -> tuple[UrdfJoint, ...]:
        return tuple(j for j in self.joints if j.type == "revolute")


def _fail(message: str, field: str = "model.path") -> InputError:
    return InputError([Problem(field, message)])


def _float(text: str | None) -> float | None:
    try:
        return None if text is None else float(text)
    except ValueError:
        return None


def read_urdf(path: Path) -> tuple[str, UrdfSummary]:
    """The URDF text and its summary; an `InputError` (one line) for anything unsupported."""
    try:
        if path.stat().st_size > MAX_BYTES:
            raise _fail(f"{path}: larger than {MAX_BYTES} bytes")
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise _fail(f"no such URDF file: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise _fail(f"cannot read {path}: {exc}") from None
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise _fail(f"{path}: not valid XML ({exc})") from None
    if root.tag != "robot":
        raise _fail(f"{path}: the root element is <{root.tag}>, not <robot>")
    links = tuple(link.get("name", "") for link in root.findall("link"))
    joints = []
    for element in root.findall("joint"):
        name, kind = element.get("name", "?"), element.get("type", "?")
        parent, child = element.find("parent"), element.find("child")
        if parent is None or child is None:
            raise _fail(f"{path}: joint {name!r} needs a <parent> and a <child>")
        if element.find("mimic") is not None:
            raise _fail(f"{path}: joint {name!r} is a mimic joint (not supported yet)")
        if kind not in SUPPORTED:
            raise _fail(
                f"{path}: joint {name!r} is {kind} (only revolute and fixed joints are "
                "supported yet)"
            )
        limit = element.find("limit")
        lower = _float(limit.get("lower")) if limit is not None else None
        upper = _float(limit.get("upper")) if limit is not None else None
        joints.append(
            UrdfJoint(name, kind, parent.get("link", ""), child.get("link", ""), lower, upper)
        )
    for joint in joints:  # else "needs exactly one root link", which hides the typo
        for role, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in links:
                raise _fail(
                    f"{path}: the {role} of joint {joint.name!r}, {link!r}, is not a link in "
                    f"the file (links: {', '.join(links[:10])}{', ...' if len(links) > 10 else ''})"
                )
    children = {j.child for j in joints}
    roots = [link for link in links if link not in children]
    if len(roots) != 1:
        raise _fail(f"{path}: needs exactly one root link, found {len(roots)} ({roots[:5]})")
    summary = UrdfSummary(root.get("name", path.stem), links, roots[0], tuple(joints))
    if not summary.revolute:
        raise _fail(f"{path}: has no revolute joint")
    return text, summary
