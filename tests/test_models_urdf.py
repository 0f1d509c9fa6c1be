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


def test_a_floating_joint_from_a_world_link_says_to_remove_it(tmp_path):
    """A simulator's URDF (world -> floating -> base): the root is the free-flying base here."""
    path = _write(tmp_path, _joint("float", "floating") + _joint("j1", "revolute", "b", "c"))
    with pytest.raises(InputError) as err:
        read_urdf(path)
    assert str(err.value).endswith(
        "joint 'float' is floating (only revolute and fixed joints are supported yet); the "
        "URDF's root link is the free-flying base: remove joint 'float' and its parent link "
        "'a' to make 'b' the root"
    )
    inner = _write(tmp_path, _joint("j1", "revolute") + _joint("float", "floating", "b", "c"))
    with pytest.raises(InputError) as err:  # not above the root: no such advice
        read_urdf(inner)
    assert str(err.value).endswith("supported yet)")


def test_a_root_link_named_world_is_refused_as_the_logs_inertial_frame(tmp_path):
    """A simulator's URDF (world -> fixed -> bus) planned, and its run.mcap's /tf made
    'world' its own parent while the base box stayed put in Foxglove."""
    path = tmp_path / "r.urdf"
    path.write_text(
        '<robot name="r"><link name="world"/><link name="b"/><link name="c"/>'
        + _joint("anchor", "fixed", "world", "b")
        + _joint("j1", "revolute", "b", "c")
        + "</robot>"
    )
    with pytest.raises(InputError) as err:
        read_urdf(path)
    assert str(err.value).endswith(
        "the root link is named 'world', the name of the inertial frame: remove joint "
        "'anchor' and link 'world' to make 'b' the root (a simulator's world link: here the "
        "root is the free-flying base)"
    )


def test_a_robots_own_base_named_world_is_to_be_renamed_not_removed(tmp_path):
    """A base with mass named 'world', or a 'world' joined by a revolute joint, was told to
    be removed with its joint: following that deleted the robot's base and a joint."""
    inertial = (
        '<inertial><mass value="10"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
    )
    for body, kind in ((inertial, "fixed"), ("", "revolute")):
        path = tmp_path / "r.urdf"
        path.write_text(
            f'<robot name="r"><link name="world">{body}</link><link name="b"/><link name="c"/>'
            + _joint("j0", kind, "world", "b")
            + _joint("j1", "revolute", "b", "c")
            + "</robot>"
        )
        with pytest.raises(InputError) as err:
            read_urdf(path)
        assert str(err.value).endswith(
            "the root link is named 'world', the name of the inertial frame: rename it (the "
            "base of the robot, the root, may have any other name)"
        ), kind


def test_a_link_defined_twice_is_named(tmp_path):
    """It said a joint's child "is not a link in the file (links: a, b, b, ...)"."""
    path = tmp_path / "r.urdf"
    path.write_text(f'<robot name="r">{LINKS}<link name="b"/>{_joint("j", "revolute")}</robot>')
    with pytest.raises(InputError) as err:
        read_urdf(path)
    assert str(err.value).endswith("link 'b' is defined twice (link names must differ)")


def test_a_xacro_file_is_named_with_how_to_expand_it(tmp_path):
    """Robot descriptions often come as xacro: its macros named no link ("the parent of joint
    'j', 'a', is not a link in the file (links: )")."""
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:macro name="l" params="n"><link name="${n}"/></xacro:macro>'
        '<xacro:l n="a"/><xacro:l n="b"/>' + _joint("j", "revolute") + "</robot>"
    )
    with pytest.raises(InputError) as err:
        read_urdf(path)
    assert str(err.value).endswith(
        "arm.urdf.xacro: a xacro file (its macros and properties are not URDF): expand it "
        "first, e.g. `xacro arm.urdf.xacro > arm.urdf`"
    )


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


def _robot(tmp_path, inertial: str = "", joint_extra: str | None = None):
    """A one-joint robot whose link b carries `inertial`; `joint_extra` replaces the joint's
    axis and limit."""
    joint = _joint("j", "revolute")
    if joint_extra is not None:
        joint = (
            f'<joint name="j" type="revolute"><parent link="a"/><child link="b"/>{joint_extra}'
            "</joint>"
        )
    path = tmp_path / "r.urdf"
    links = f'<link name="a"/><link name="b">{inertial}</link>'
    path.write_text(f'<robot name="r">{links}{joint}</robot>')
    return path


def _one_line(tmp_path, **kwargs) -> str:
    with pytest.raises(InputError) as err:
        read_urdf(_robot(tmp_path, **kwargs))
    text = str(err.value)
    assert "model.path" in text and "\n" not in text
    return text


INERTIA = '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>'


@pytest.mark.parametrize(
    ("inertial", "expected"),
    [
        (f'<inertial><mass value="-3"/>{INERTIA}</inertial>', "link 'b': mass must be"),
        (f'<inertial><mass value="heavy"/>{INERTIA}</inertial>', "link 'b': mass must be"),
        (f"<inertial>{INERTIA}</inertial>", "link 'b': its <inertial> has no <mass"),
        ('<inertial><mass value="2"/></inertial>', "link 'b': its <inertial> has no <inertia"),
        (
            '<inertial><mass value="2"/><inertia ixx="1" iyy="1" izz="1"/></inertial>',
            "link 'b': <inertia> needs six numbers",
        ),
        (
            '<inertial><mass value="2"/>'
            '<inertia ixx="0.1" ixy="5" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>',
            "link 'b': its inertia matrix is not positive semi-definite",
        ),
        (  # a small part's (grams and millimetres): as wrong as a large one's
            '<inertial><mass value="0.001"/>'
            '<inertia ixx="1e-10" ixy="5e-10" ixz="0" iyy="1e-10" iyz="0" izz="1e-10"/></inertial>',
            "link 'b': its inertia matrix is not positive semi-definite",
        ),
    ],
)
def test_an_inertial_without_physical_meaning_is_named(tmp_path, inertial, expected):
    """Pinocchio loads these (a missing <inertia> with urdfdom's C++ lines on stderr) into a
    model that plans nonsense or fails far from the mistake."""
    assert expected in _one_line(tmp_path, inertial=inertial)


def test_a_massless_link_and_a_valid_inertial_are_read(tmp_path):
    inertial = f'<inertial><origin xyz="0 0 1"/><mass value="2"/>{INERTIA}</inertial>'
    assert read_urdf(_robot(tmp_path, inertial=inertial))[1].revolute[0].name == "j"
    assert read_urdf(_robot(tmp_path))[1].revolute[0].name == "j"


@pytest.mark.parametrize(
    "inertia",
    [
        'ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"',  # a point mass
        'ixx="1E-1" ixy="-0.0" ixz="0" iyy="1e-1" iyz="0" izz="0"',  # a thin rod along z
        'ixx="1e-9" ixy="0" ixz="0" iyy="2e-9" iyz="0" izz="2.5e-9"',  # a small part
        # a rod along (1, 1, 0) / sqrt 2, written rounded: its zero eigenvalue is -1e-17
        'ixx="0.05" ixy="-0.05" ixz="0" iyy="0.05" iyz="0" izz="0.1"',
    ],
)
def test_an_odd_but_valid_inertia_is_read(tmp_path, inertia):
    inertial = f'<inertial><mass value="1.5e0"/><inertia {inertia}/></inertial>'
    assert read_urdf(_robot(tmp_path, inertial=inertial))[1].revolute[0].name == "j"


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        ('<axis xyz="0 0 1"/>', "revolute joint 'j' has no <limit"),
        ('<axis xyz="0 0 0"/><limit lower="-1" upper="1"/>', "joint 'j': axis must be 3 numbers"),
        ('<axis xyz="0 1"/><limit lower="-1" upper="1"/>', "joint 'j': axis must be 3 numbers"),
        ('<limit lower="-1" upper="one"/>', "joint 'j': limit upper is not a number"),
        (  # URDF's defaults 0 and 0: it was read as a joint limited to [0, 0]
            '<axis xyz="0 0 1"/><limit effort="10" velocity="1"/>',
            "revolute joint 'j': its <limit> has no lower and no upper (URDF's default for both "
            "is 0, a joint that cannot move); give its range",
        ),
    ],
)
def test_a_revolute_joint_without_limit_or_axis_is_named(tmp_path, extra, expected):
    assert expected in _one_line(tmp_path, joint_extra=extra)


def test_a_revolute_joint_without_an_axis_turns_about_x_as_urdf_says(tmp_path):
    limit = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
    text, summary = read_urdf(_robot(tmp_path, joint_extra=limit))
    assert (summary.revolute[0].lower, summary.revolute[0].upper) == (-1.0, 1.0)
    pin = pytest.importorskip("pinocchio")  # and Pinocchio reads it so: about x
    assert pin.buildModelFromXML(text).joints[1].shortname() == "JointModelRX"


def test_limits_in_the_wrong_order_are_named(tmp_path):
    text = _one_line(tmp_path, joint_extra='<axis xyz="0 0 1"/><limit lower="1" upper="-1"/>')
    assert "joint 'j': limit lower 1 is above upper -1" in text


def test_native_stderr_in_two_threads_gives_each_its_lines_and_stderr_back():
    """Overlapping captures: the later one saved the earlier one's temporary file as
    "stderr" and put it back, so the process's stderr went to a deleted file for good (a
    Dask worker's threads building URDF models)."""
    import os
    import threading

    from stratcli.models.urdf import native_stderr

    before = os.fstat(2)
    first_in, second_in, first_out = (threading.Event() for _ in range(3))
    said = {}

    def first():
        with native_stderr() as lines:
            first_in.set()
            second_in.wait(0.5)  # the second thread starts its capture here, if it may
            os.write(2, b"from first\n")
        first_out.set()  # ends first: not in the reverse order of starting
        said["first"] = lines

    def second():
        first_in.wait(5)
        with native_stderr() as lines:
            second_in.set()
            first_out.wait(0.5)
            os.write(2, b"from second\n")
        said["second"] = lines

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    kept = os.dup(2)  # put back whatever happens: the rest of the tests write there
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join(10)
        after = os.fstat(2)
    finally:
        os.dup2(kept, 2)
        os.close(kept)
    assert (after.st_dev, after.st_ino) == (before.st_dev, before.st_ino)
    assert said == {"first": ["from first"], "second": ["from second"]}


def test_native_stderr_without_descriptor_2_captures_nothing():
    import subprocess
    import sys

    code = (
        "from stratcli.models.urdf import native_stderr\n"
        "with native_stderr() as lines: pass\n"
        "print(lines)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], stderr=subprocess.DEVNULL, capture_output=False,
        stdout=subprocess.PIPE, text=True, check=False, pass_fds=(),
        preexec_fn=lambda: __import__("os").close(2),
    )  # fmt: skip
    assert (done.returncode, done.stdout.strip()) == (0, "[]")


def test_a_fork_while_another_thread_captures_does_not_hang_the_child():
    """The child of a fork made while a thread held the capture's lock got it held by nobody:
    its first capture waited for ever."""
    import os
    import threading
    import time

    from stratcli.models import urdf

    holding, release = threading.Event(), threading.Event()

    def hold():
        with urdf.native_stderr():
            holding.set()
            release.wait(10)

    thread = threading.Thread(target=hold)
    thread.start()
    holding.wait(10)
    try:
        child = os.fork()
        if child == 0:  # pragma: no cover - the child's exit code is the result
            code = 1
            try:
                with urdf.native_stderr():
                    code = 0
            finally:
                os._exit(code)
        deadline = time.monotonic() + 10
        while (done := os.waitpid(child, os.WNOHANG)) == (0, 0) and time.monotonic() < deadline:
            time.sleep(0.01)
        if done == (0, 0):
            os.kill(child, 9)
            os.waitpid(child, 0)
        assert done != (0, 0) and os.waitstatus_to_exitcode(done[1]) == 0
    finally:
        release.set()
        thread.join()


def test_a_link_of_mass_zero_with_inertia_is_refused(tmp_path):
    """A typo'd mass (0 with the inertia kept) planned a robot without its bus's mass, drawn
    as a box 8 m across (its size is its inertia over its mass)."""
    inertial = (
        '<inertial><mass value="{}"/><inertia ixx="{}" ixy="0" ixz="0" iyy="{}" iyz="0" izz="{}"/>'
        "</inertial>"
    )
    for mass, inertia, refused in ((0, 1.0, True), (0, 0, False), (1.0, 1.0, False)):
        body = inertial.format(mass, inertia, inertia, inertia)
        path = tmp_path / "r.urdf"
        path.write_text(
            f'<robot name="r"><link name="a">{body}</link><link name="b"/><link name="c"/>'
            f"{_joint('j', 'revolute')}{_joint('k', 'revolute', 'b', 'c')}</robot>"
        )
        if refused:
            with pytest.raises(InputError) as err:
                read_urdf(path)
            assert str(err.value).endswith(
                "link 'a': mass 0 with a non-zero inertia (a massless link has neither; is its "
                "mass missing?)"
            )
        else:
            read_urdf(path)


def test_a_joint_origin_rpy_past_a_full_turn_is_refused_as_degrees_maybe(tmp_path):
    """`<origin rpy="0 0 90">` (90 degrees meant) placed the joint at 90 rad, silently."""
    joint = _joint("j", "revolute").replace("<axis", '<origin xyz="0 0 0" rpy="0 0 90"/><axis')
    path = _write(tmp_path, joint)
    with pytest.raises(InputError) as err:
        read_urdf(path)
    assert str(err.value).endswith(
        "joint 'j': <origin rpy='0 0 90'> turns by 90 rad, past a full turn: URDF angles are "
        "radians (90 degrees is 1.5708)"
    )
    fine = joint.replace('rpy="0 0 90"', 'rpy="0 0 1.5708"') + _joint("k", "revolute", "b", "c")
    read_urdf(_write(tmp_path, fine))
