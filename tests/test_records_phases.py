"""Every phase of a run is timed: in manifest.json (additions only) and in the outcome."""

from __future__ import annotations

import json
from pathlib import Path

from mcap.reader import make_reader
from typer.testing import CliRunner

from stratcli import api
from stratcli.cli import app
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "sim1_l_c1.toml"
PLANNED = ("import", "check", "compile", "planning")
RECORDED = ("record imports", "sample", "run.mcap", "plots")  # the log while drawn


def _is_timing(entry) -> bool:
    return set(entry) == {"wall_s", "cpu_s"} and all(v >= 0 for v in entry.values())


def test_the_manifest_and_the_outcome_time_every_phase(tmp_path):
    outcome = api.plan_run(load_scenario(SCENARIO))
    assert list(outcome.phases) == list(PLANNED)
    run_dir = api.write_record(tmp_path, outcome, argv=["test"])
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert list(manifest["phases"]) == [*PLANNED, *RECORDED]
    assert all(_is_timing(t) for t in manifest["phases"].values())
    # the keys manifest.json had before phases were added are still there
    old = {"schema", "stratplan", "command", "compile_time_s", "planning_time_s", "exit_code"}
    assert old <= set(manifest)
    assert list(outcome.phases) == [*PLANNED, *RECORDED, "write", "total"]
    # run.mcap is built while the figures are drawn; its copy of the manifest, added after
    # them, has every phase manifest.json has
    with (run_dir / "run.mcap").open("rb") as f:
        (copy,) = [m.metadata for m in make_reader(f).iter_metadata() if m.name == "manifest"]
    assert json.loads(copy["phases"]) == manifest["phases"]
    total = outcome.phases["total"]
    assert total["wall_s"] >= sum(t["wall_s"] for k, t in outcome.phases.items() if k != "total")


def test_plan_prints_the_total_beside_the_planning_time(tmp_path):
    result = CliRunner().invoke(app, ["plan", str(SCENARIO), "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    footer = " ".join(result.output.split())
    assert "planned in" in footer and " s in all · record:" in footer
    (run_dir,) = tmp_path.iterdir()
    assert not (run_dir / "motion.gif").exists()  # the GIF is opt-in (--animation)


def test_a_comparison_records_its_planning_phase(tmp_path):
    """compare-sequences' manifest has the comparison as `planning` (it had `import` only)."""
    task = load_scenario(ROOT / "scenarios" / "sim4_auto.toml")
    outcome = api.compare_sequences(task, max_length=2, jobs=1)
    run_dir = api.write_record(tmp_path, outcome, argv=["test"])
    phases = json.loads((run_dir / "manifest.json").read_text())["phases"]
    imports, *rest = RECORDED
    assert list(phases) == ["import", "planning", imports, "comparison files", *rest]
    assert all(_is_timing(t) for t in phases.values())
    assert phases["planning"]["wall_s"] >= outcome.comparison.wall_time * 0.99
    # run.mcap's copy has every phase too (it lacked "comparison files", timed after it)
    with (run_dir / "run.mcap").open("rb") as f:
        (copy,) = [m.metadata for m in make_reader(f).iter_metadata() if m.name == "manifest"]
    assert json.loads(copy["phases"]) == phases


def test_the_footer_reports_the_compile_and_the_check_each_as_timed(tmp_path):
    """'model compiled in' is the compile phase of manifest.json (it included the check's
    time, 0.45 s of a two-arm check beside a 2 ms compile); the check is reported as such,
    and not at all when it did not run."""
    import re

    for flags, checked in (([], True), (["--no-check"], False)):
        out = tmp_path / str(checked)
        result = CliRunner().invoke(app, ["plan", str(SCENARIO), "--out", str(out), *flags])
        assert result.exit_code == 0, result.output
        footer = " ".join(result.output.split())
        found = re.search(r"model compiled in (\d+) ms(?:, checked in (\d+) ms)?\)", footer)
        assert found, footer
        (run_dir,) = out.iterdir()
        manifest = json.loads((run_dir / "manifest.json").read_text())
        phases = manifest["phases"]
        assert manifest["compile_time_s"] == phases["compile"]["wall_s"]
        assert int(found[1]) == round(phases["compile"]["wall_s"] * 1e3)
        assert (found[2] is not None) == checked
        if checked:
            assert abs(int(found[2]) - phases["check"]["wall_s"] * 1e3) <= 1
