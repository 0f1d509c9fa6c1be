"""A sweep directory is self-contained: its sweep.toml, beside its copies of the base scenario
(and a URDF base's robot), plans the same tasks wherever the directory is moved."""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import pytest

from stratcli import tomlwrite
from stratcli.records import sweepdir
from stratcli.records.model_files import SCENARIO_FILE, sweep_files
from stratcli.sweep.spec import load_sweep

ROOT = Path(__file__).resolve().parents[1]
GRID = '[sweep.grid]\n"goal.q2" = [-1.0, -0.9]\n'


def _copied(sweep, out: Path) -> Path:
    """The directory's copies written as `run_sweep` writes them, then moved elsewhere."""
    sweepdir.prepare(out, {"digest": sweep.digest}, sweep_files(sweep, set(sweepdir.NAMES)), False)
    moved = out.parent / "elsewhere" / "deeper" / out.name
    moved.parent.mkdir(parents=True)
    shutil.move(out, moved)
    return moved


def test_a_relative_base_path_is_the_copy_of_the_base(tmp_path):
    folder = tmp_path / "sweeps"
    folder.mkdir()
    base = ROOT / "scenarios" / "sim4_task_d.toml"
    relative = Path(*[".."] * len(folder.parts[1:])) / Path(*base.parts[1:])
    (folder / "s.toml").write_text(f'[sweep]\nname = "t"\nscenario = "{relative}"\n{GRID}')
    sweep = load_sweep(folder / "s.toml")
    moved = _copied(sweep, tmp_path / "out")
    assert (moved / SCENARIO_FILE).read_text() == base.read_text()  # as given, comments too
    copy = load_sweep(moved / "sweep.toml")
    assert tomllib.loads((moved / "sweep.toml").read_text())["sweep"]["scenario"] == SCENARIO_FILE
    assert copy.digest == sweep.digest and copy.base == sweep.base
    assert [t.scenario for t in copy.tasks()] == [t.scenario for t in sweep.tasks()]


def test_a_urdf_base_brings_its_robot_and_keeps_the_digest(tmp_path):
    base = ROOT / "scenarios" / "spatial" / "arm3_reorient.toml"
    text = f'[sweep]\nname = "t"\nscenario = "{base}"\n[sweep.grid]\n"goal.j1" = [0.1, 0.2]\n'
    (tmp_path / "s.toml").write_text(text)
    sweep = load_sweep(tmp_path / "s.toml")
    moved = _copied(sweep, tmp_path / "out")
    scenario = tomllib.loads((moved / SCENARIO_FILE).read_text())
    assert scenario["model"]["path"] == "arm3.urdf"
    assert (moved / "arm3.urdf").read_text() == (ROOT / "robots" / "arm3.urdf").read_text()
    copy = load_sweep(moved / "sweep.toml")
    assert copy.digest == sweep.digest  # the robot's content decides, not its file's place
    assert copy.base["model"]["path"] == str((moved / "arm3.urdf").absolute())


def test_an_inline_urdf_base_names_the_copy_and_an_edited_robot_changes_the_digest(tmp_path):
    robot = tmp_path / "robots" / "arm3.urdf"
    robot.parent.mkdir()
    shutil.copy(ROOT / "robots" / "arm3.urdf", robot)
    scenario = tomllib.loads((ROOT / "scenarios" / "spatial" / "arm3_reorient.toml").read_text())
    scenario["model"]["path"] = "robots/arm3.urdf"  # relative to the sweep file
    sweep = {"name": "t", "grid": {"goal.j1": [0.1, 0.2]}}
    text = tomlwrite.dumps({"sweep": sweep, "scenario": scenario})
    (tmp_path / "s.toml").write_text(text)
    sweep = load_sweep(tmp_path / "s.toml")
    files = sweep_files(sweep, set(sweepdir.NAMES))
    assert sorted(files) == ["arm3.urdf", "sweep.toml"]
    assert tomllib.loads(files["sweep.toml"])["scenario"]["model"]["path"] == "arm3.urdf"
    moved = _copied(sweep, tmp_path / "out")
    digest = sweep.digest
    assert load_sweep(moved / "sweep.toml").digest == digest
    robot.write_text(robot.read_text().replace("<robot", "<!-- edited -->\n<robot", 1))
    assert sweep.digest == digest  # the robot as loaded
    assert load_sweep(tmp_path / "s.toml").digest != digest


def test_a_json_base_a_records_resolved_json_is_read_and_copied_as_toml(tmp_path):
    """`stratplan plan RUN/resolved.json` worked, a sweep over it was 'not valid TOML'."""
    import stratcli

    plan = stratcli.plan(ROOT / "scenarios" / "sim4_task_d.toml")
    run = stratcli.write_record(tmp_path / "runs", plan, animation=False)
    text = f'[sweep]\nname = "t"\nscenario = "{run / "resolved.json"}"\n{GRID}'
    (tmp_path / "s.toml").write_text(text)
    sweep = load_sweep(tmp_path / "s.toml")
    moved = _copied(sweep, tmp_path / "out")
    tomllib.loads((moved / SCENARIO_FILE).read_text())  # TOML, not the JSON as given
    copy = load_sweep(moved / "sweep.toml")
    assert copy.digest == sweep.digest


def test_a_sweep_directorys_summary_given_as_the_sweep_file_is_one_line(tmp_path):
    """`stratplan sweep OUT/sweep.json` printed a line per summary key."""
    from stratcli.errors import InputError

    out = tmp_path / "out"
    (out).mkdir()
    (out / sweepdir.SPEC).write_text("{}")
    (out / sweepdir.SUMMARY).write_text('{"name": "t", "counts": {}}')
    with pytest.raises(InputError) as info:
        load_sweep(out / sweepdir.SUMMARY)
    assert len(info.value.problems) == 1
    assert "not a sweep file: the sweep file is" in str(info.value)
