"""A URDF file where a scenario is expected: `models` and `check` describe it, the commands
that plan say in one line that a scenario names it (not "not valid TOML ... line 1")."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
ARM3 = ROOT / "robots" / "arm3.urdf"

pin = pytest.importorskip("pinocchio")

import stratcli  # noqa: E402
from stratcli.cli import app  # noqa: E402
from stratcli.errors import InputError  # noqa: E402


def test_models_describes_a_urdf_file_as_its_scenario_would():
    result = CliRunner().invoke(app, ["models", str(ARM3)])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("urdf model of arm3.urdf: URDF robot 'ff_arm3', 15 kg")
    assert "coordinates: j1, j2, j3, rx, ry, rz" in result.output
    scenario = ROOT / "scenarios" / "spatial" / "arm3_reorient.toml"
    same = CliRunner().invoke(app, ["models", str(scenario)])
    assert result.output.splitlines()[1:] == same.output.splitlines()[1:]  # the same model


def test_models_json_of_a_urdf_has_the_numbers_its_description_states():
    """`models FILE --json` left out the mass and the limits the table's description states:
    they are there as numbers, the URDF's own (read here from its XML)."""
    import json
    import xml.etree.ElementTree as ET

    result = CliRunner().invoke(app, ["models", str(ARM3), "--json"])
    assert result.exit_code == 0, result.output
    facts = json.loads(result.stdout)
    assert facts["description"].startswith("URDF robot 'ff_arm3', 15 kg")
    joints = [j for j in ET.parse(ARM3).getroot().findall("joint") if j.get("type") == "revolute"]
    limits = {j.get("name"): j.find("limit") for j in joints}
    assert facts["joint_limits"] == {
        name: [float(e.get("lower")), float(e.get("upper"))] for name, e in limits.items()
    }
    assert facts["velocity_limits"] == {
        name: float(e.get("velocity")) for name, e in limits.items()
    }
    masses = [float(m.get("value")) for m in ET.parse(ARM3).getroot().iter("mass")]
    assert facts["mass"] == pytest.approx(sum(masses), rel=1e-12)
    assert facts["base"] == "base"


def test_check_takes_a_urdf_file_at_zero_joints_or_at():
    report = stratcli.check_controllability(ARM3, samples=3)
    assert report.title == "URDF arm3.urdf"
    assert report.document["at"] == [0.0] * 6 and report.document["model"] == "urdf"
    # as README says of the golden arm at j1 = 0: S1 turns the base about y only
    assert not report.document["strongly_controllable"] and report.controllable
    result = CliRunner().invoke(app, ["check", str(ARM3), "--samples", "3", "--at", "0, 0.3"])
    assert result.exit_code == 2
    assert "error: --at: needs 6 values (j1, j2, j3, rx, ry, rz), got 2" in result.output


@pytest.mark.parametrize("command", ["plan", "decompose", "compare-sequences", "check"])
def test_a_command_given_a_urdf_says_a_scenario_names_it(tmp_path, command):
    robot = tmp_path / "robot.xml"  # by its content, not its name
    robot.write_text("\n  " + ARM3.read_text())
    if command == "check":  # a bad URDF: one line naming it, as in a scenario
        robot.write_text(ARM3.read_text().replace('type="revolute"', 'type="continuous"', 1))
    result = CliRunner().invoke(app, [command, str(robot)])
    assert result.exit_code == 2, result.output
    (line,) = result.output.strip().splitlines()
    if command == "check":
        assert line.startswith(f"error: {robot}: joint 'j1' is continuous")  # named once
        return
    assert line == (
        f"error: {robot}: XML, not a scenario file (TOML); a URDF robot is named in a "
        f'scenario\'s [model] table (kind = "urdf", path = "robot.xml"), and `stratplan '
        f"models {robot}` describes it"
    )
    with pytest.raises(InputError, match="XML, not a scenario file"):
        stratcli.load_scenario(robot)


def test_an_empty_or_broken_urdf_file_is_one_line_about_the_urdf():
    """`models empty.urdf` said "the scenario is empty ..."; a truncated URDF named its path
    twice ("trunc.urdf: /tmp/.../trunc.urdf: not valid XML")."""
    import tempfile

    with tempfile.TemporaryDirectory() as where:
        empty, cut = Path(where) / "empty.urdf", Path(where) / "cut.urdf"
        empty.write_text("")
        cut.write_text(ARM3.read_text()[:300])
        for path in (empty, cut):
            result = CliRunner().invoke(app, ["models", str(path)])
            assert result.exit_code == 2
            (line,) = result.output.strip().splitlines()
            assert line.startswith(f"error: {path}: not valid XML ("), line


def test_across_strata_the_rank_is_never_below_a_strata_own_closure():
    """arm3 on S3 alone needs degree-3 brackets (its closure spans 5 of 6); across strata
    at degree 2 the check said rank 3, below that: the cross closure now holds each stratum's
    own closure too, in the full coordinates a URDF stratum's fields are padded to."""
    from stratcli.controllability import sequence_report
    from stratcli.models.specs import UrdfModel, build_system

    system = build_system(UrdfModel(kind="urdf", path=str(ARM3)))
    report = sequence_report(system, ["S3"], [[0.0] * system.n])
    assert not report.eq2 and report.cross_rank is not None
    assert report.cross_rank.min() >= report.sum_rank.min() == 5
