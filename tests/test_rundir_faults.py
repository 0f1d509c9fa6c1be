"""Faults while writing and filling a run record: nothing complete-looking is ever left.

`write_run` is interrupted at each of its system calls in turn (fsync of every file, chmod,
rename); each time the cleanup branch must remove the hidden `.partial` directory, raise
`RecordError` and leave `list_records` empty. Records of failed or extreme plans (NaN
samples, too much re-integration work, many legs) are still written.
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT
from mcap.reader import make_reader

import stratcli.simulate as simulate
from stratcli.errors import RecordError
from stratcli.records import rundir
from stratcli.records.mcap_log import _json, _log_time, mcap_bytes
from stratcli.records.plots import render_plots
from stratcli.records.result import result_document
from stratcli.records.rundir import run_name, write_run
from stratcli.records.store import list_records
from stratcli.scenario import load_scenario
from stratcli.stratified import plan_sequence

FILES = {
    "scenario.toml": 'name = "x"\n',
    "result.json": {"schema": "stratplan.result/1"},
    "manifest.json": {"started": "2026-01-01T00:00:00Z"},
    "run.mcap": b"\x89MCAP",
}


class Boom(OSError):
    pass


def _failing(real, counter: dict, when: int):
    def wrapper(*args, **kwargs):
        counter["n"] += 1
        if counter["n"] == when:
            raise Boom(28, "No space left on device")
        return real(*args, **kwargs)

    return wrapper


def _calls(monkeypatch, name: str, out: Path) -> int:
    """How many times write_run calls os.<name> on a clean write."""
    counter = {"n": 0}
    monkeypatch.setattr(os, name, _failing(getattr(os, name), counter, -1))
    write_run(out, "probe", FILES)
    monkeypatch.undo()
    return counter["n"]


@pytest.mark.parametrize("call", ["fsync", "chmod", "rename"])
def test_interrupted_writer_leaves_no_record(tmp_path, monkeypatch, call):
    total = _calls(monkeypatch, call, tmp_path / "count")
    assert total >= 1
    real_rmtree = shutil.rmtree
    cleaned: list = []

    def rmtree(path, *args, **kwargs):
        cleaned.append(path)
        return real_rmtree(path, *args, **kwargs)

    for when in range(1, total + 1):
        out = tmp_path / f"{call}-{when}"
        cleaned.clear()
        counter = {"n": 0}
        monkeypatch.setattr(os, call, _failing(getattr(os, call), counter, when))
        monkeypatch.setattr(shutil, "rmtree", rmtree)
        with pytest.raises(RecordError, match="No space left on device"):
            write_run(out, "run", FILES)
        monkeypatch.undo()
        assert cleaned, "the cleanup branch did not run"
        assert list(out.iterdir()) == []  # not even a hidden .partial directory
        assert list_records(out) == []


def test_out_that_is_a_file_is_a_record_error(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(RecordError, match="cannot write the run record"):
        write_run(tmp_path / "file", "run", FILES)


def test_long_and_odd_names_are_cut_and_written(tmp_path):
    for scenario in ("n" * 300, "é" * 200, "a/b\x00c"):
        name = run_name(scenario, "text")
        assert len(name.encode()) <= 128 and "/" not in name and "\x00" not in name
        assert write_run(tmp_path, name, FILES).is_dir()
    assert len(list_records(tmp_path)) == 3  # readable back as records
    names = {run_name("n" * 300, "a"), run_name("n" * 300, "b")}
    assert len(names) == 2  # the hash of the text keeps truncated names apart


# ---------------------------------------------------------------------------------------------
# Records of failed or extreme plans
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def unicycle_plan():
    task = load_scenario(ROOT / "scenarios" / "unicycle.toml")
    return task, plan_sequence(task.system, task.start, task.legs, task.settings)


def test_reintegration_is_bounded_and_says_so(unicycle_plan, monkeypatch):
    _, plan = unicycle_plan
    monkeypatch.setattr(simulate, "MAX_EVALUATIONS", 20)
    traj = simulate.sample(plan, 50)
    assert np.isnan(traj.q).all() and len(traj.notes) == len(plan.legs)
    assert "could not be re-integrated" in traj.notes[0]
    monkeypatch.undo()
    traj = simulate.sample(plan, 50)
    assert np.isfinite(traj.q).all() and traj.notes == ()


def test_nan_samples_still_give_a_valid_log_and_plots(unicycle_plan, monkeypatch):
    task, plan = unicycle_plan
    monkeypatch.setattr(simulate, "MAX_EVALUATIONS", 20)
    traj = simulate.sample(plan, 50)
    doc = result_document(plan, task.scenario.name, task.model_name, None)
    data = mcap_bytes(plan, traj, doc, {}, task.text, task.scenario.name)
    messages = list(make_reader(io.BytesIO(data)).iter_messages())
    state = next(json.loads(m.data) for _, c, m in messages if c.topic == "/state")
    assert set(state["q"].values()) == {None}  # NaN written as null
    files = render_plots(plan, traj, "nan")  # plots that cannot be drawn are left out
    assert set(files) <= {"configuration.png", "controls.png"}
    assert "controls.png" in files


def test_long_plans_are_plotted_without_per_leg_labels(unicycle_plan, monkeypatch):
    import stratcli.records.plots as plots

    _, plan = unicycle_plan
    traj = simulate.sample(plan, 20)
    monkeypatch.setattr(plots, "MAX_LABELLED_LEGS", 0)
    fig = plots.configuration_figure(plan, traj, "t")
    assert "leg labels omitted" in fig._suptitle.get_text()
    assert len(fig.axes[0].texts) == 0


def test_json_and_log_times_of_non_finite_values():
    assert json.loads(_json({"a": [1.0, float("nan"), float("inf")], "b": -np.inf})) == {
        "a": [1.0, None, None],
        "b": None,
    }
    assert _log_time(5, float("nan")) == 5
    assert _log_time(5, 1e308) == 2**64 - 1
    assert _log_time(5, 1.0) == 5 + 10**9


def test_rundir_module_names_its_limit():
    assert rundir.MAX_NAME_BYTES <= 128


def test_non_finite_json_values_are_written_as_null(tmp_path):
    files = dict(FILES, **{"result.json": {"schema": "stratplan.result/1", "e": float("nan")}})
    run = write_run(tmp_path, "nan", files)
    assert json.loads((run / "result.json").read_text())["e"] is None
