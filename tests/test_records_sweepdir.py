"""The sweep directory's files: rows appended whole and fsync'd, a torn last line ignored
and cut before appending, the table in task order with exact floats, atomic outputs."""

from __future__ import annotations

import csv
import io

import pytest

from stratcli.errors import InputError
from stratcli.records import sweepdir


def test_a_torn_last_line_is_ignored_and_cut_before_appending(tmp_path):
    path = tmp_path / sweepdir.ROWS
    with sweepdir.RowLog(path) as log:
        log.append({"index": 1, "status": "ok", "energy": 0.1 + 0.2})
        log.append({"index": 0, "status": "failed", "energy": float("nan")})
    with open(path, "ab") as fh:
        fh.write(b'{"index": 2, "sta')  # killed while writing
    rows = sweepdir.read_rows(path)
    assert sorted(rows) == [0, 1] and rows[1]["energy"] == 0.1 + 0.2
    assert rows[0]["energy"] is None  # not finite: null
    with sweepdir.RowLog(path) as log:
        log.append({"index": 2, "status": "ok", "energy": 3.0})
    assert path.read_bytes().count(b"\n") == 3 and b"sta\n" not in path.read_bytes()
    assert sorted(sweepdir.read_rows(path)) == [0, 1, 2]


def test_the_first_row_of_a_task_wins(tmp_path):
    """A task's row written twice (a resumed sweep planning a torn one again): the first."""
    path = tmp_path / sweepdir.ROWS
    with sweepdir.RowLog(path) as log:
        log.append({"index": 0, "status": "ok", "energy": 1.0})
        log.append({"index": 0, "status": "failed", "energy": 2.0})
    assert sweepdir.read_rows(path) == {0: {"index": 0, "status": "ok", "energy": 1.0}}


def test_the_summary_counts_and_energies_are_those_of_the_rows():
    """Min, median (of an even count: the mean of the middle two) and max of the ok rows'
    energies; the success rate of the rows there are (missing tasks apart); the best task."""
    from stratcli.sweep.outputs import summarise

    spec = {"name": "s", "mode": "legs", "kind": "grid", "count": 6, "keys": ["goal.q1"]}
    energies = {0: 4.0, 1: 1.0, 2: None, 3: 3.0, 4: 2.0}
    rows = {
        k: {"index": k, "goal.q1": 0.1 * k, "status": "ok" if e else "failed", "energy": e}
        for k, e in energies.items()
    }
    summary = summarise(spec, rows, missing=[5])
    assert summary["energy"] == {"min": 1.0, "median": 2.5, "max": 4.0}
    assert summary["counts"]["ok"] == 4 and summary["counts"]["failed"] == 1
    assert summary["success_rate"] == 4 / 5 and summary["missing"] == 1
    assert summary["best"]["index"] == 1 and summary["best"]["inputs"] == {"goal.q1": 0.1}


def test_the_table_is_in_task_order_and_reads_back_exactly(tmp_path):
    rows = {
        2: {"index": 2, "goal.q1": 1 / 3, "status": "ok", "energy": 2 / 7, "sequence": "S1,S2"},
        0: {"index": 0, "goal.q1": -1e-17, "status": "invalid", "message": "a, b\nc"},
    }
    text = sweepdir.table_text(["goal.q1"], rows)
    table = list(csv.DictReader(io.StringIO(text)))
    assert [r["index"] for r in table] == ["0", "2"]
    assert list(table[0])[:4] == ["index", "goal.q1", "status", "energy"]
    assert float(table[1]["energy"]) == 2 / 7 and float(table[0]["goal.q1"]) == -1e-17
    assert table[0]["message"] == "a, b\nc" and table[0]["energy"] == ""
    assert table[1]["sequence"] == "S1,S2"


def test_prepare_refuses_an_existing_or_different_sweep(tmp_path):
    spec = {"format": sweepdir.FORMAT, "digest": "a"}
    assert sweepdir.prepare(tmp_path / "s", spec, {"sweep.toml": "text"}, resume=False) == {}
    assert sweepdir.is_sweep_dir(tmp_path / "s")
    assert (tmp_path / "s" / sweepdir.FILE_TEXT).read_text() == "text"
    with pytest.raises(InputError) as info:  # Python's words: the arguments, not the flags
        sweepdir.prepare(tmp_path / "s", spec, {"sweep.toml": "text"}, resume=False)
    assert str(info.value) == (
        f"out={str(tmp_path / 's')!r}: already holds a sweep, unfinished (0 tasks done); "
        "add resume=True to finish it, or choose another out"
    )
    with pytest.raises(InputError, match="another sweep file"):
        sweepdir.prepare(
            tmp_path / "s", {**spec, "digest": "b"}, {"sweep.toml": "text"}, resume=True
        )
    assert sweepdir.prepare(tmp_path / "s", spec, {"sweep.toml": "text"}, resume=True) == {}
    (tmp_path / "f").write_text("")
    with pytest.raises(InputError, match="not a directory"):
        sweepdir.prepare(tmp_path / "f", spec, {"sweep.toml": "text"}, resume=False)


def test_finished_means_every_row_and_a_summary_that_counts_them(tmp_path):
    """The one predicate both the refusal without --resume and --resume itself use."""
    rows = {k: {"index": k} for k in range(3)}
    assert sweepdir.finished_summary(tmp_path, rows, 3) is None  # no sweep.json yet
    (tmp_path / sweepdir.SUMMARY).write_text('{"done": 2}')  # an older, partial summary
    assert sweepdir.finished_summary(tmp_path, rows, 3) is None
    (tmp_path / sweepdir.SUMMARY).write_text('{"done": 3}')
    assert sweepdir.finished_summary(tmp_path, rows, 3) == {"done": 3}
    (tmp_path / sweepdir.SUMMARY).write_text('{"done": 4}')
    assert sweepdir.finished_summary(tmp_path, {**rows, 7: {}}, 4) is None  # 7 is no task of 4
    assert sweepdir.finished_summary(tmp_path, {**rows, 3: {}}, 4) == {"done": 4}
    (tmp_path / sweepdir.SUMMARY).write_text("{torn")
    assert sweepdir.finished_summary(tmp_path, {**rows, 3: {}}, 4) is None


def test_sweep_json_is_valid_json_with_a_nan_at_any_depth(tmp_path):
    """Only top-level non-finite numbers became null: a NaN inside `energy` or `best` wrote
    `NaN`, which is not JSON (a strict reader, e.g. JavaScript's, refuses the file)."""
    import json

    summary = {
        "count": 2,
        "ratio": float("nan"),
        "energy": {"min": float("nan"), "median": 1.5, "max": float("inf")},
        "best": {"index": 0, "inputs": {"goal.q1": float("-inf")}, "values": [1.0, float("nan")]},
    }
    sweepdir.write_outputs(tmp_path, ["goal.q1"], {}, summary)
    doc = json.loads((tmp_path / sweepdir.SUMMARY).read_text(), parse_constant=pytest.fail)
    assert doc["ratio"] is None and doc["energy"] == {"min": None, "median": 1.5, "max": None}
    assert doc["best"] == {"index": 0, "inputs": {"goal.q1": None}, "values": [1.0, None]}
