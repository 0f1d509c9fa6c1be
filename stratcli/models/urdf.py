"""Reading a URDF far enough to validate it before Pinocchio builds the model (no `pin` needed).

`read_urdf` returns the robot's name, its links, its root link and its joints in file order,
and rejects, one line naming the joint, what the spatial models do not support yet:
prismatic, continuous, planar and floating joints and mimic joints. Fixed joints are
supported (Pinocchio merges the child's inertia into its parent). It also rejects, naming the
link or joint, what Pinocchio would load without a word (or with urdfdom's C++ messages on
stderr) into a model with no physical meaning: an `<inertial>` without its `<mass>` or
`<inertia>`, a negative mass, an inertia matrix that is not positive semi-definite, a
revolute joint without `<limit>` (or without its lower and upper) or with a zero axis. Every
problem is an `InputError` whose field is `model.path`.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
import threading
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, Problem

__all__ = [
    "UrdfJoint",
    "UrdfSummary",
    "lock_indices",
    "native_stderr",
    "read_urdf",
    "urdfdom_errors",
]

MAX_BYTES = 5_000_000
SUPPORTED = ("revolute", "fixed")
XACRO = "{http://www.ros.org/wiki/xacro}"  # the namespace of xacro's elements


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
    if any(str(e.tag).startswith(XACRO) for e in root.iter()):  # else "not a link" of ${...}
        raise _fail(
            f"{path}: a xacro file (its macros and properties are not URDF): expand it first, "
            f"e.g. `xacro {path.name} > {path.name.removesuffix('.xacro').removesuffix('.urdf')}"
            ".urdf`"
        )
    links = tuple(link.get("name", "") for link in root.findall("link"))
    twice = sorted({name for name in links if links.count(name) > 1})
    if twice:  # else a joint's child "is not a link in the file (links: a, a, ...)"
        raise _fail(f"{path}: link {twice[0]!r} is defined twice (link names must differ)")
    for link in root.findall("link"):
        _check_inertial(path, link.get("name", "?"), link.find("inertial"))
    joints = []
    for element in root.findall("joint"):
        name, kind = element.get("name", "?"), element.get("type", "?")
        parent, child = element.find("parent"), element.find("child")
        if parent is None or child is None:
            raise _fail(f"{path}: joint {name!r} needs a <parent> and a <child>")
        if element.find("mimic") is not None:
            raise _fail(f"{path}: joint {name!r} is a mimic joint (not supported yet)")
        if kind not in SUPPORTED:
            hint = ""
            top = parent.get("link", "") not in {
                c.get("link") for c in root.iter("child")
            }  # a simulator's world link: the root is free-flying here
            if kind == "floating" and top:
                hint = (
                    f"; the URDF's root link is the free-flying base: remove joint {name!r} "
                    f"and its parent link {parent.get('link', '')!r} to make "
                    f"{child.get('link', '')!r} the root"
                )
            raise _fail(
                f"{path}: joint {name!r} is {kind} (only revolute and fixed joints are "
                f"supported yet){hint}"
            )
        _check_origin(path, f"joint {name!r}", element.find("origin"))
        limit = element.find("limit")
        if kind == "revolute":
            _check_revolute(path, name, element, limit)
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
    if roots[0] == WORLD:  # the log's inertial frame: /tf would make it its own parent
        below = [j for j in joints if j.parent == WORLD]
        massless = _mass(root, WORLD) == 0.0
        hint = (  # a simulator's world link; a real base named so is renamed, not removed
            f"remove joint {below[0].name!r} and link {WORLD!r} to make {below[0].child!r} "
            "the root (a simulator's world link: here the root is the free-flying base)"
            if len(below) == 1 and below[0].type == "fixed" and massless
            else "rename it (the base of the robot, the root, may have any other name)"
        )
        raise _fail(f"{path}: the root link is named {WORLD!r}, the name of the inertial "
                    f"frame: {hint}")  # fmt: skip
    summary = UrdfSummary(root.get("name", path.stem), links, roots[0], tuple(joints))
    if not summary.revolute:
        raise _fail(f"{path}: has no revolute joint")
    return text, summary


def _mass(root: ET.Element, link: str) -> float:
    """A link's mass from its `<inertial>` (0 without one; checked by `_check_inertial`)."""
    for element in root.findall("link"):
        mass = element.find("inertial/mass") if element.get("name") == link else None
        if mass is not None:
            return (_numbers(mass.get("value")) or [0.0])[0]
    return 0.0


WORLD = "world"  # the inertial frame's name in run.mcap's /tf (`records.mcap_spatial`)
INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _numbers(text: str | None) -> list[float] | None:
    """The finite numbers of a URDF attribute ("0 0 1"), or None when it is not that."""
    try:
        values = [float(x) for x in (text or "").split()]
    except ValueError:
        return None
    return values if values and all(math.isfinite(v) for v in values) else None


def _check_inertial(path: Path, link: str, inertial: ET.Element | None) -> None:
    """A link's `<inertial>`: none (a massless link) or a mass >= 0 and a positive
    semi-definite inertia matrix."""
    if inertial is None:
        return
    mass, inertia = inertial.find("mass"), inertial.find("inertia")
    if mass is None or inertia is None:
        missing = "<mass value=...>" if mass is None else "<inertia ixx=... izz=...>"
        raise _fail(f"{path}: link {link!r}: its <inertial> has no {missing}")
    value = _numbers(mass.get("value"))
    if value is None or len(value) != 1 or value[0] < 0:
        raise _fail(
            f"{path}: link {link!r}: mass must be a number >= 0 (got {mass.get('value')!r})"
        )
    entries = [_numbers(inertia.get(key)) for key in INERTIA]
    if any(e is None or len(e) != 1 for e in entries):
        given = ", ".join(f"{k}={inertia.get(k)!r}" for k in INERTIA)
        raise _fail(f"{path}: link {link!r}: <inertia> needs six numbers ({given})")
    xx, xy, xz, yy, yz, zz = (e[0] for e in entries)
    matrix = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    if value[0] == 0 and np.abs(matrix).max() > 0:  # a body with inertia has mass
        raise _fail(
            f"{path}: link {link!r}: mass 0 with a non-zero inertia (a massless link has "
            "neither; is its mass missing?)"
        )
    smallest = float(np.linalg.eigvalsh(matrix)[0])
    if smallest < -1e-9 * float(np.abs(matrix).max()):  # relative: small links are small
        raise _fail(
            f"{path}: link {link!r}: its inertia matrix is not positive semi-definite "
            f"(smallest eigenvalue {smallest:.3g}); check ixy, ixz, iyz and their signs"
        )


def _check_origin(path: Path, what: str, origin: ET.Element | None) -> None:
    """An `<origin rpy>` angle past a full turn: URDF angles are radians, and `rpy="0 0 90"`
    (90 degrees meant) placed the joint at 90 rad, silently."""
    rpy = _numbers(origin.get("rpy")) if origin is not None else None
    past = [a for a in rpy or [] if abs(a) > 2 * math.pi]
    if past:
        raise _fail(
            f"{path}: {what}: <origin rpy={origin.get('rpy')!r}> turns by {past[0]:g} rad, past "
            f"a full turn: URDF angles are radians ({past[0]:g} degrees is "
            f"{math.radians(past[0]):.6g})"
        )


def _check_revolute(path: Path, joint: str, element: ET.Element, limit) -> None:
    """A revolute joint has `<limit lower upper>` (URDF requires it; lower and upper default
    to 0, so one without either could not move) and a nonzero axis."""
    if limit is None:
        raise _fail(
            f"{path}: revolute joint {joint!r} has no <limit lower=... upper=... effort=... "
            "velocity=...> (URDF requires one)"
        )
    bounds = []
    for key in ("lower", "upper"):
        value = limit.get(key)
        bounds.append(None if value is None else _numbers(value))
        if value is not None and bounds[-1] is None:
            raise _fail(f"{path}: joint {joint!r}: limit {key} is not a number (got {value!r})")
    if bounds == [None, None]:  # what a continuous joint's <limit> has; here a joint stuck at 0
        raise _fail(
            f"{path}: revolute joint {joint!r}: its <limit> has no lower and no upper (URDF's "
            "default for both is 0, a joint that cannot move); give its range"
        )
    if all(bounds) and bounds[0][0] > bounds[1][0]:
        raise _fail(
            f"{path}: joint {joint!r}: limit lower {bounds[0][0]:g} is above upper {bounds[1][0]:g}"
        )
    axis = element.find("axis")
    xyz = _numbers(axis.get("xyz")) if axis is not None else [1.0, 0.0, 0.0]
    if xyz is None or len(xyz) != 3 or not any(xyz):
        given = axis.get("xyz") if axis is not None else None
        raise _fail(f"{path}: joint {joint!r}: axis must be 3 numbers, not all 0 (got {given!r})")


def lock_indices(strata, names: tuple[str, ...], summary: UrdfSummary) -> list[tuple[int, ...]]:
    """`[model] strata` (lock sets by joint name) as sorted indices into `names` (the revolute
    joints in model order); one problem per bad lock set, naming `model.strata[i]`."""
    fixed = {j.name for j in summary.joints if j.type == "fixed"}
    lock_sets: list[tuple[int, ...]] = []
    problems = []
    for i, locks in enumerate(strata):
        unknown = [x for x in locks if x not in names]
        if not unknown and len(set(locks)) < len(locks):  # ["j1", "j1"]: S1, without a word
            problems.append(
                Problem(f"model.strata[{i}]", f"lock set {list(locks)} names a joint twice")
            )
            continue
        if unknown or not locks or len(set(locks)) >= len(names):
            kinds = (
                ("unknown", [x for x in unknown if x not in fixed]),
                ("fixed joints, which never move", [x for x in unknown if x in fixed]),
            )
            why = "; ".join(f"{label}: {', '.join(group)}" for label, group in kinds if group)
            problems.append(
                Problem(
                    f"model.strata[{i}]",
                    f"lock set {list(locks)} must name 1..{len(names) - 1} distinct joints "
                    f"of {', '.join(names)}" + (f" ({why})" if why else ""),
                )
            )
            continue
        locked = tuple(sorted({names.index(x) for x in locks}))
        if locked in lock_sets:  # else one stratum fewer than given, without a word
            first = f"model.strata[{lock_sets.index(locked)}]"
            why = f"lock set {list(locks)} repeats {first}"
            problems.append(Problem(f"model.strata[{i}]", why))
        lock_sets.append(locked)
    if problems:
        raise InputError(problems)
    return lock_sets


@contextmanager
def native_stderr() -> Iterator[list[str]]:
    """Capture what native code (urdfdom, inside Pinocchio) writes to file descriptor 2: its
    lines are in the yielded list once the block ends. The descriptor is the process's: for
    the milliseconds a model takes to build, other threads' native stderr lands there too
    (and is passed on by the caller when the model loads). Captures in several threads take
    turns (`_CAPTURE`): overlapping, the later one saved the earlier one's file as "stderr"
    and put it back, and the process's stderr went to a deleted file for good."""
    lines: list[str] = []
    with _CAPTURE:
        try:
            if sys.stderr is not None:
                sys.stderr.flush()
            saved = os.dup(2)
        except (OSError, ValueError):  # no descriptor 2 (closed) or no stderr: nothing to capture
            yield lines
            return
        with tempfile.TemporaryFile() as tmp:
            os.dup2(tmp.fileno(), 2)
            try:
                yield lines
            finally:
                os.dup2(saved, 2)
                os.close(saved)
                tmp.seek(0)
                lines.extend(tmp.read().decode("utf-8", "replace").splitlines())


_CAPTURE = threading.RLock()  # one redirection of descriptor 2 at a time (nested: same thread)


def _new_lock_after_fork() -> None:  # a fork while another thread captured: not held there
    global _CAPTURE
    _CAPTURE = threading.RLock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_new_lock_after_fork)


def urdfdom_errors(lines: list[str]) -> str:
    """urdfdom's "Error:" messages in one line, without the C++ source locations."""
    found = [x.split(":", 1)[1].strip() for x in lines if x.startswith("Error:")]
    return "; ".join(x for x in found if x)
