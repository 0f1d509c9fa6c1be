"""Spatial models from URDF: the connection and its derivative, strata, the audit, pickling,
and the exit-2 install hint without Pinocchio."""

import builtins
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from stratcli.errors import InputError
from stratcli.models import spatial
from stratcli.models.spatial import INSTALL, load_spatial

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "robots"


def test_without_pinocchio_the_install_command_is_given(monkeypatch):
    real = builtins.__import__

    def no_pin(name, *args, **kwargs):
        if name == "pinocchio":
            raise ImportError("no pinocchio")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pin)
    with pytest.raises(InputError) as err:
        spatial.load_pinocchio()
    assert INSTALL.startswith("pip install 'stratplan[spatial]'")
    assert INSTALL in str(err.value)


pin = pytest.importorskip("pinocchio")


@pytest.fixture(scope="module")
def arm3():
    return load_spatial(ROBOTS / "arm3.urdf")


def test_joints_strata_and_limits(arm3):
    assert arm3.states == ("j1", "j2", "j3", "rx", "ry", "rz")
    assert list(arm3.strata) == ["S1", "S2", "S3"]
    assert arm3.strata["S2"].active == (0, 2)
    np.testing.assert_allclose(arm3.spatial.lower, [-3.14, -2.0, -2.5])
    named = load_spatial(ROBOTS / "arm3.urdf", strata=[["j1", "j3"]])
    assert list(named.strata) == ["S13"]
    with pytest.raises(InputError, match="unknown: jx"):
        load_spatial(ROBOTS / "arm3.urdf", strata=[["jx"]])


def test_connection_derivative_matches_finite_differences(arm3):
    rng = np.random.default_rng(0)
    robot = arm3.spatial
    q, u = rng.uniform(-1, 1, (4, 3)), rng.normal(size=(4, 3))
    _, D = robot.connection(q, u)
    h = 1e-6
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        fd = (robot.connection(q + e)[0] - robot.connection(q - e)[0])[:, 3:] @ u[:, :, None]
        np.testing.assert_allclose(D[:, :, k], fd[:, :, 0] / (2 * h), atol=1e-8)


def test_zero_momentum_and_fixed_centre_of_mass(arm3):
    from stratcli import so3

    robot = arm3.spatial
    q, R = np.array([0.3, -0.7, 1.1]), so3.exp([0.2, -0.4, 0.9])
    h = robot.momentum(q, R, np.array([0.5, -1.0, 2.0]))
    assert np.abs(h).max() < 1e-13
    p = robot.base_position(q[None], R)[0]
    x = robot.configuration(q, R, p)
    np.testing.assert_allclose(pin.centerOfMass(robot.model, robot.data, x), 0.0, atol=1e-14)


def test_a_spatial_system_and_its_task_have_a_repr():
    """A notebook shows a loaded URDF scenario: its repr read the symbolic `fields`, which a
    URDF model has not (ModelError)."""
    from stratcli.scenario import load_scenario

    task = load_scenario(ROBOTS.parent / "scenarios" / "spatial" / "arm3_reorient.toml")
    assert (
        repr(task.system)
        == "SpatialSystem('ff_arm3': coordinates j1, j2, j3, rx, ry, rz; strata S1, S2, S3)"
    )
    assert repr(task).startswith("Task('arm3_reorient': urdf model, legs (S3, S1, S3), energy ")


def test_system_pickles_and_rebuilds(arm3):
    again = pickle.loads(pickle.dumps(arm3))
    q = np.array([[0.1, 0.2, 0.3]])
    np.testing.assert_array_equal(again.spatial.connection(q)[0], arm3.spatial.connection(q)[0])


def test_reserved_and_unsupported(tmp_path):
    text = (ROBOTS / "arm3.urdf").read_text().replace('name="j2"', 'name="rx"')
    (tmp_path / "r.urdf").write_text(text)
    with pytest.raises(InputError, match="reserved"):
        load_spatial(tmp_path / "r.urdf")
    with pytest.raises(InputError, match="root link 'base'"):
        load_spatial(ROBOTS / "arm3.urdf", base="l1")


def test_angular_rows_alone_give_the_same_rate_and_derivative():
    robot = load_spatial(ROBOTS / "bus_arm7.urdf").spatial
    rng = np.random.default_rng(1)
    q, u = rng.uniform(-2, 2, (5, 7)), rng.normal(size=(5, 7))
    S, D = robot.connection(q, u)
    S_w, D_w = robot.angular(q, u)
    np.testing.assert_allclose(S_w, S[:, 3:], atol=1e-14)
    np.testing.assert_allclose(D_w, D, atol=1e-14)


def test_base_box_is_the_box_of_the_base_inertia(tmp_path):
    """A base given the inertia of a uniform 1.2 × 0.6 × 0.4 m box, rotated and off-centre,
    is drawn as that box: same edges, centre and axes (up to the axes' signs)."""
    a, m = np.array([1.2, 0.6, 0.4]), 30.0
    moments = m * (a @ a - a**2) / 12.0  # I_a = m (b² + c²) / 12
    c, s = np.cos(0.4), np.sin(0.4)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    inertia = Rz @ np.diag(moments) @ Rz.T
    pairs = {"xx": (0, 0), "xy": (0, 1), "xz": (0, 2), "yy": (1, 1), "yz": (1, 2), "zz": (2, 2)}
    attrs = " ".join(f'i{p}="{float(inertia[i, j])!r}"' for p, (i, j) in pairs.items())
    text, found = re.subn(
        r'<link name="base">.*?</link>',
        f'<link name="base"><inertial><origin xyz="0.1 -0.2 0.05"/><mass value="{m}"/>'
        f"<inertia {attrs}/></inertial></link>",
        (ROBOTS / "arm3.urdf").read_text(),
    )
    assert found == 1
    (tmp_path / "box.urdf").write_text(text)
    centre, axes, edges = load_spatial(tmp_path / "box.urdf").spatial.base_box()
    order = np.argsort(-edges)
    np.testing.assert_allclose(edges[order], a, rtol=1e-9)
    np.testing.assert_allclose(centre, [0.1, -0.2, 0.05], atol=1e-12)
    np.testing.assert_allclose(np.abs(axes[:, order].T @ Rz), np.eye(3), atol=1e-9)


def test_a_lock_set_naming_a_fixed_joint_or_given_twice_is_named(tmp_path):
    text = (ROBOTS / "arm3.urdf").read_text()
    extra = (
        '<link name="tool"/><joint name="tool_mount" type="fixed"><parent link="l3"/>'
        '<child link="tool"/><origin xyz="0.5 0 0"/></joint></robot>'
    )
    path = tmp_path / "arm3_tool.urdf"
    path.write_text(text.replace("</robot>", extra))
    with pytest.raises(InputError) as err:
        load_spatial(path, strata=[["j3"], ["tool_mount", "jx"], ["j3"]])
    lines = str(err.value).splitlines()
    assert len(lines) == 2
    assert lines[0].endswith("(unknown: jx; fixed joints, which never move: tool_mount)")
    assert "model.strata[1]" in lines[0]
    assert "model.strata[2]: lock set ['j3'] repeats model.strata[0]" in lines[1]
    assert list(load_spatial(path, strata=[["j3"], ["j1", "j2"]]).strata) == ["S3", "S12"]
    with pytest.raises(InputError) as err:  # ["j1", "j1"] was S1, without a word
        load_spatial(path, strata=[["j9"], ["j1", "j1"]])
    lines = str(err.value).splitlines()
    assert len(lines) == 2 and "model.strata[0]" in lines[0]
    assert lines[1].endswith("model.strata[1]: lock set ['j1', 'j1'] names a joint twice")


def test_what_urdfdom_says_of_a_model_it_loads_never_goes_to_stdout(monkeypatch, capsys):
    """Passed on to stderr; without one (pythonw, sys.stderr None) print(file=None) wrote it
    on stdout, in the middle of `--json` output."""
    import contextlib
    import sys

    @contextlib.contextmanager
    def saying():
        yield ["Warning: something urdfdom says"]

    monkeypatch.setattr(spatial, "native_stderr", saying)
    load_spatial(ROBOTS / "arm3.urdf")
    assert capsys.readouterr() == ("", "Warning: something urdfdom says\n")
    monkeypatch.setattr(sys, "stderr", None)
    load_spatial(ROBOTS / "arm3.urdf")
    assert capsys.readouterr().out == ""


def test_urdfdom_s_reason_is_the_message_not_lines_on_stderr(tmp_path, capfd):
    # a URDF that passes our reading but not urdfdom's: its C++ lines ("Error: ... at line
    # 231 in /project/urdfdom/...") went to stderr, the message said only "The XML stream
    # does not contain a valid URDF model"
    text = (ROBOTS / "arm3.urdf").read_text()
    path = tmp_path / "bad_origin.urdf"
    path.write_text(text.replace('<origin xyz="0 0 0.5"/><axis', '<origin xyz="0 zero 0.5"/><axis'))
    with pytest.raises(InputError) as err:
        load_spatial(path)
    text = str(err.value)
    assert "Unable to parse component [zero]" in text and "joint [j2]" in text
    assert "\n" not in text and ".cpp" not in text
    assert capfd.readouterr().err == ""


def test_a_stratum_of_a_joint_that_moves_no_mass_says_why_it_cannot_steer(tmp_path):
    """A link without <inertial> is valid URDF (a frame), but a joint that moves only such
    links turns nothing: the check's refusal names it instead of leaving the user to guess."""
    import stratcli
    from stratcli.errors import NotControllableError

    urdf = (ROBOTS / "arm3.urdf").read_text()
    massless = re.sub(r'<link name="l3">.*?</link>', '<link name="l3"/>', urdf)
    assert massless != urdf
    (tmp_path / "arm3.urdf").write_text(massless)
    assert load_spatial(tmp_path / "arm3.urdf").spatial.inert_joints == ("j3",)
    assert load_spatial(ROBOTS / "arm3.urdf").spatial.inert_joints == ()
    scenario = (ROOT / "scenarios" / "spatial" / "arm3_reorient.toml").read_text()
    scenario = scenario.replace('path = "../../robots/arm3.urdf"', 'path = "arm3.urdf"')
    (tmp_path / "t.toml").write_text(scenario)
    with pytest.raises(NotControllableError) as exc:
        stratcli.plan(tmp_path / "t.toml")
    assert "j3 moves no mass: the links it moves have no <inertial>" in str(exc.value)
