"""URDF reading: unsupported joints are rejected with one line naming the joint."""

import pytest

from stratcli.errors import InputError
from stratcli.models.urdf import read_urdf

LINKS = '<link name="a"/><link name="b"/><link name="c"/>'


def _write(tmp_path, joints: str):
    path = tmp_path / "r.urdf"
    path.write_text(f'<robot name="r">{LINKS}{joints}</robot>')
    return path


def _joint(name, kind, parent="a", child="b", extra=""):
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>{extra}</joint>'
    )


@pytest.mark.parametrize("kind", ["prismatic", "continuous", "planar", "floating"])
def test_unsupported_joint_types_are_named(tmp_path, kind):
    path = _write(tmp_path, _joint("ok", "revolute") + _joint("bad", kind, "b", "c"))
    with pytest.raises(InputError) as err:
        read_urdf(path)
    text = str(err.value)
    assert "'bad'" in text and kind in text and "model.path" in text and "\n" not in text


def test_mimic_joint_is_rejected(tmp_path):
    mimic = _joint("m", "revolute", "b", "c", '<mimic joint="ok"/>')
    with pytest.raises(InputError, match="'m' is a mimic joint"):
        read_urdf(_write(tmp_path, _joint("ok", "revolute") + mimic))


def test_fixed_joints_are_allowed_and_limits_read(tmp_path):
    _, summary = read_urdf(
        _write(tmp_path, _joint("j", "revolute") + _joint("f", "fixed", "b", "c"))
    )
    assert summary.root == "a"
    assert [j.name for j in summary.revolute] == ["j"]
    assert (summary.revolute[0].lower, summary.revolute[0].upper) == (-1.0, 1.0)


def test_missing_file_and_bad_xml(tmp_path):
    with pytest.raises(InputError, match="no such URDF file"):
        read_urdf(tmp_path / "nope.urdf")
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot")
    with pytest.raises(InputError, match="not valid XML"):
        read_urdf(bad)


@pytest.mark.parametrize("role", ["parent", "child"])
def test_a_joint_naming_a_missing_link_is_named(tmp_path, role):
    """Not "needs exactly one root link, found 2": the typo itself, joint and link named."""
    parent, child = ("x", "c") if role == "parent" else ("b", "x")
    path = _write(tmp_path, _joint("j1", "revolute") + _joint("j2", "revolute", parent, child))
    with pytest.raises(InputError) as err:
        read_urdf(path)
    text = str(err.value)
    assert f"the {role} of joint 'j2', 'x', is not a link in the file (links: a, b, c)" in text
    assert "exactly one root" not in text and "\n" not in text
