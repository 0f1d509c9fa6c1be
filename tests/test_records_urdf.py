"""Run records of URDF robots: read back by `load_run` (configurations by joint name), and
self-contained (the URDF beside scenario.toml, which names it; its sha256 in the manifest)."""

from __future__ import annotations

import hashlib
import json
import shutil
import tomllib
from pathlib import Path

import pytest

from stratcli.errors import InputError
from stratcli.records.model_files import with_model_path

ROOT = Path(__file__).resolve().parents[1]

SCENARIO = """name = "small"
# a comment the record keeps
[model]
kind = "urdf"
path = "robots/mine.urdf"   # relative to this file

[task]
start = { j1 = 0, j2 = "10deg", j3 = 0, attitude = [0, 0, 0] }
goal = { j1 = 0, j2 = "10deg", j3 = "*", attitude = [0.1, 0, 0] }

[planner]
objective = "newton"

[[legs]]
stratum = "S3"
"""


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """A URDF scenario beside its robots/ folder, planned and recorded as `stratplan plan`
    does; the scenario's folder is removed afterwards, so that the record has only itself.
    Also (before that) the plan value recorded as the README's snippet does, or the error."""
    pytest.importorskip("pinocchio")
    from stratcli import api
    from stratcli.scenario import load_scenario

    home = tmp_path_factory.mktemp("home")
    (home / "robots").mkdir()
    shutil.copy(ROOT / "robots" / "arm3.urdf", home / "robots" / "mine.urdf")
    (home / "small.toml").write_text(SCENARIO)
    outcome = api.plan_run(load_scenario(home / "small.toml"))
    assert outcome.ok
    run = api.write_record(tmp_path_factory.mktemp("runs"), outcome, argv=["test"])
    try:
        value = api.write_record(tmp_path_factory.mktemp("runs"), outcome.result)
    except InputError as exc:
        value = exc
    moved = tmp_path_factory.mktemp("elsewhere") / "record"
    shutil.copytree(run, moved)
    shutil.rmtree(home)
    return outcome.result, moved, value


def test_write_record_of_a_plan_value_finds_its_urdf(record):
    """`stratcli.write_record(out, plan)` read the plan's scenario again relative to the
    working directory, where its URDF is not."""
    plan, _, value = record
    assert isinstance(value, Path), value
    assert json.loads((value / "result.json").read_text()) == plan.to_dict()
    assert (value / "scenario.toml").read_text() == (
        SCENARIO.replace('"robots/mine.urdf"', '"mine.urdf"')
    )


def test_load_run_reads_a_urdf_record_with_configurations_by_name(record):
    """It failed on every URDF scenario file: the plain schema refused `start = { j1 = ...}`."""
    import stratcli

    plan, run, _ = record
    again = stratcli.load_run(run)
    assert again.to_dict() == plan.to_dict()
    _, q, _ = again.sample(50)  # the model rebuilt from the record's own URDF
    assert q[0, 1] == pytest.approx(0.17453292519943295)
    assert q[-1] == pytest.approx(plan.end, abs=1e-6)


def test_the_record_holds_its_urdf_and_replans_from_its_own_scenario(record):
    import stratcli

    plan, run, _ = record
    urdf = (ROOT / "robots" / "arm3.urdf").read_text()
    assert (run / "mine.urdf").read_text() == urdf
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["urdf"]["file"] == "mine.urdf"
    assert manifest["urdf"]["sha256"] == hashlib.sha256(urdf.encode()).hexdigest()
    assert manifest["urdf"]["source"].endswith("robots/mine.urdf")
    assert manifest["scenario_sha256"] == hashlib.sha256(SCENARIO.encode()).hexdigest()
    text = (run / "scenario.toml").read_text()  # as given, but for the path (comments kept)
    assert text == SCENARIO.replace('"robots/mine.urdf"', '"mine.urdf"')
    again = stratcli.plan(run / "scenario.toml")  # the scenario's own folder is gone
    assert again.total_energy == pytest.approx(plan.total_energy, rel=1e-9)
    assert again.legs[0].coefficients == pytest.approx(plan.legs[0].coefficients, abs=1e-9)


def test_the_records_foxglove_files_name_no_path_outside_it(record):
    """layout.json named the scenario's own URDF path (gone once the scenario's folder is):
    its 3-D panel now draws the robot from run.mcap's /robot_description, which holds the
    URDF, and the log's attachments are the record's scenario.toml and its copy of the URDF."""
    import io

    from conftest import mcap_messages
    from mcap.reader import make_reader

    from stratcli.records.foxglove_layout import THREE_D

    _, run, _ = record
    urdf = (run / "mine.urdf").read_text()
    text = (run / "layout.json").read_text()
    assert "robots/mine.urdf" not in text and "filePath" not in text
    three_d = json.loads(text)["configById"][THREE_D]
    assert three_d["topics"]["/robot_description"] == {"visible": True}
    data = (run / "run.mcap").read_bytes()
    ((_, message),) = mcap_messages(data, "/robot_description")
    assert message == {"data": urdf}
    attachments = {a.name: a.data for a in make_reader(io.BytesIO(data)).iter_attachments()}
    assert attachments["mine.urdf"].decode() == urdf
    assert attachments["scenario.toml"].decode() == (run / "scenario.toml").read_text()
    assert json.loads(attachments["layout.json"]) == json.loads(text)


def test_an_older_record_without_its_urdf_falls_back_on_resolved_json(record, tmp_path):
    import stratcli

    plan, run, _ = record
    old = tmp_path / "old"
    shutil.copytree(run, old)
    (old / "mine.urdf").unlink()
    (old / "scenario.toml").write_text(SCENARIO)  # relative to a scenario file elsewhere
    source = tmp_path / "arm3.urdf"
    shutil.copy(ROOT / "robots" / "arm3.urdf", source)
    resolved = json.loads((old / "resolved.json").read_text())
    resolved["model"]["path"] = str(source)
    (old / "resolved.json").write_text(json.dumps(resolved))
    assert stratcli.load_run(old).total_energy == plan.total_energy


@pytest.mark.parametrize(
    "text, words",
    [
        ("name = [", "not TOML"),
        (SCENARIO.replace('j3 = 0, attitude = [0, 0, 0] }', "attitude = [0, 0, 0] }"),
         "task.start: missing joints j3"),
        (SCENARIO.replace('"robots/mine.urdf"', '"nope.urdf"').replace("stratum", "strata"),
         "model.path: no such URDF file"),
        (SCENARIO.replace('objective = "newton"', "objective = 3\ntolerance = -1"),
         "planner.tolerance: must be at least 1e-12 "
         "(got -1); and 1 more)"),
    ],
)  # fmt: skip
def test_a_damaged_scenario_toml_is_one_line_naming_the_file(record, tmp_path, text, words):
    import stratcli

    _, run, _ = record
    damaged = tmp_path / "damaged"
    shutil.copytree(run, damaged)
    (damaged / "scenario.toml").write_text(text.replace("robots/mine.urdf", "mine.urdf"))
    with pytest.raises(InputError) as err:
        stratcli.load_run(damaged)
    message = str(err.value)
    assert message.startswith(f"{damaged}/scenario.toml: not a valid scenario (")
    assert words in message and "\n" not in message and "pydantic" not in message


def test_with_model_path_changes_the_path_only():
    inline = (
        'name = "x"  # path = "a"\ndescription = "path = \\"b\\""\n'
        "model = { kind = \"urdf\", path = '../r.urdf' }\n"
    )
    out = with_model_path(inline, "r.urdf")
    assert out == inline.replace("'../r.urdf'", '"r.urdf"')
    spread = 'name = "x"\n[model]\nkind = "urdf"\npath = """\n../r.urdf"""\n'
    out = with_model_path(spread, "r.urdf")  # not one the text can take: written out again
    assert tomllib.loads(out) == {"name": "x", "model": {"kind": "urdf", "path": "r.urdf"}}


@pytest.mark.parametrize(
    "path, name",
    [("/a/arm.urdf", "arm.urdf"), ("/a/result.json", "robot.urdf"), ("/a/.hidden", "robot.urdf")],
)
def test_the_urdf_never_replaces_another_file_of_the_record(path, name):
    from types import SimpleNamespace

    from stratcli.records.model_files import model_files

    robot = SimpleNamespace(text="<robot/>", path=path)
    task = SimpleNamespace(
        system=SimpleNamespace(spatial=robot),
        scenario=SimpleNamespace(model=SimpleNamespace(path=path)),
        text=f'name = "x"\n[model]\nkind = "urdf"\npath = "{path}"\n',
    )
    text, files, entry = model_files(task, {"result.json", "scenario.toml"})
    assert files == {name: "<robot/>"} and entry["file"] == name and entry["source"] == path
    assert tomllib.loads(text)["model"]["path"] == name
