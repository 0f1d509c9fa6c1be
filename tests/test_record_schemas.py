"""The JSON Schemas of result.json, manifest.json, comparison.json and sweep.json
(`stratcli.record_schema`) against real documents: plans of every kind, records written to
disk, a comparison and a sweep; and a key that no schema describes fails validation."""

from __future__ import annotations

import copy
import json
import typing
from pathlib import Path

import jsonschema
import pytest

import stratcli
from stratcli.api import plan_run
from stratcli.records.rundir import finite_or_none
from stratcli.records.schemas import NAMES
from stratcli.settings import Continuity
from stratcli.status import Status

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"
DOCUMENT_KEY = {"result": "schema", "manifest": "schema", "comparison": "schema", "sweep": "schema"}


def validator(name: str) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(stratcli.record_schema(name))


def errors(name: str, doc: dict) -> list[str]:
    """Each validation error as `path: message`, with those under a nullable's `anyOf`."""

    def lines(e: jsonschema.ValidationError) -> list[str]:
        own = f"{'/'.join(map(str, e.absolute_path))}: {e.message[:200]}"
        return [own] if not e.context else [line for c in e.context for line in lines(c)]

    return [line for e in validator(name).iter_errors(doc) for line in lines(e)]


def as_written(doc: dict) -> dict:
    """A document as a run directory holds it (non-finite numbers null, as `rundir` writes)."""
    return json.loads(json.dumps(finite_or_none(doc), allow_nan=False))


def read(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


# ------------------------------------------------------------------------------------------
# Real documents, made once for the module
# ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def task_a():
    return stratcli.load_scenario(SCENARIOS / "sim4_task_a.toml")


@pytest.fixture(scope="module")
def failed_plan(task_a):
    settings = {"objective": "newton", "max_iterations": 1, "restarts": 0}
    plan = stratcli.plan(task_a.with_changes({"planner": settings}))
    assert not plan.ok
    return plan


@pytest.fixture(scope="module")
def constrained_run():
    """What `stratplan plan` runs on a scenario with [constraints] (its phases included)."""
    return plan_run(stratcli.load_scenario(SCENARIOS / "sim4_task_d_constrained.toml"))


@pytest.fixture(scope="module")
def plans(task_a, failed_plan, constrained_run):
    """Plans by kind: the energy objective, Newton, a failed one, Lie legs, constraints."""
    hybrid = stratcli.load_scenario(SCENARIOS / "sim3_hybrid.toml")
    return {
        "energy": stratcli.plan(task_a),
        "newton": stratcli.plan(task_a.with_changes({"planner": {"objective": "newton"}})),
        "failed": failed_plan,
        "lie": stratcli.plan(hybrid),
        "constrained": constrained_run.result,
    }


@pytest.fixture(scope="module")
def records(tmp_path_factory, failed_plan, constrained_run):
    """Run directories written by `write_record`: a comparison (max_length 2), a failed plan
    and the command's outcome of a plan under [constraints]."""
    out = tmp_path_factory.mktemp("runs")
    auto = stratcli.load_scenario(SCENARIOS / "sim4_auto.toml")
    comparison = stratcli.compare_sequences(
        auto.with_changes({"decompose": {"max_length": 2}}), jobs=1
    )
    return {
        "compare": stratcli.write_record(out, comparison, argv=["stratplan", "compare"]),
        "failed": stratcli.write_record(out, failed_plan, argv=["stratplan", "plan"]),
        "constrained": stratcli.write_record(out, constrained_run, argv=["stratplan", "plan"]),
    }


SWEEP = """[sweep]
name = "schemas"
scenario = "{scenario}"
mode = "legs"
set = {{ "planner.objective" = "newton", "planner.restarts" = 0 }}

[[sweep.task]]
"goal.q1" = -0.5
"planner.max_iterations" = 100

[[sweep.task]]
"goal.q1" = -1.0
"planner.max_iterations" = 1
"""


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory):
    """A two-task sweep, one task failing (its run record written, as by default)."""
    where = tmp_path_factory.mktemp("sweep")
    path = where / "schemas.toml"
    path.write_text(SWEEP.format(scenario=SCENARIOS / "sim4_task_a.toml"))
    stratcli.run_sweep(path, where / "out", jobs=1)
    return where / "out"


# ------------------------------------------------------------------------------------------
# The schemas themselves
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", NAMES)
def test_each_schema_is_a_draft_2020_12_schema_named_as_its_document(name):
    schema = stratcli.record_schema(name)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    document = schema["properties"][DOCUMENT_KEY[name]]["const"]
    assert schema["$id"] == schema["title"] == document == f"stratplan.{name}/1"
    assert schema["additionalProperties"] is False


def test_record_schema_is_a_fresh_dict_and_refuses_unknown_names():
    first = stratcli.record_schema("result")
    first["title"] = "changed"
    assert stratcli.record_schema("result")["title"] == "stratplan.result/1"
    with pytest.raises(stratcli.InputError, match="name: must be result, manifest"):
        stratcli.record_schema("resolved")
    with pytest.raises(TypeError, match="name"):
        stratcli.record_schema(1)


def test_the_schemas_are_package_data():
    schemas = Path(stratcli.__file__).parent / "records" / "schemas"
    assert sorted(p.name for p in schemas.glob("*.schema.json")) == sorted(
        f"{n}.schema.json" for n in NAMES
    )
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert '"stratcli.records.schemas" = ["*.schema.json"]' in pyproject


def test_the_enumerations_are_the_codes_own():
    defs = stratcli.record_schema("result")["$defs"]
    assert set(defs["leg"]["properties"]["status"]["enum"]) == {s.key for s in Status}
    props = stratcli.record_schema("result")["properties"]
    assert props["continuity"]["enum"] == list(typing.get_args(Continuity))


# ------------------------------------------------------------------------------------------
# Real documents validate
# ------------------------------------------------------------------------------------------

KINDS = ("energy", "newton", "failed", "lie", "constrained")


@pytest.mark.parametrize("kind", KINDS)
def test_result_documents_of_every_kind_of_plan_validate(plans, kind):
    doc = as_written(plans[kind].to_dict())
    assert errors("result", doc) == []
    described = set(stratcli.record_schema("result")["properties"]) - {"attitude"}
    assert set(doc) == described  # every documented key is written, and nothing else


def test_the_plans_cover_what_the_schema_makes_optional(plans):
    """The kinds above exercise the nullable sections (else the test proves less)."""
    docs = {k: as_written(p.to_dict()) for k, p in plans.items()}
    assert docs["energy"]["optimisation"]["starts"] and docs["newton"]["optimisation"] is None
    assert docs["failed"]["status"] == "failed" and docs["failed"]["legs"][0]["status"] != "success"
    assert docs["failed"]["planned_legs"] > len(docs["failed"]["legs"])
    assert {leg["method"] for leg in docs["lie"]["legs"]} == {"newton", "lie"}
    assert len(docs["lie"]["legs"][-1]["pieces"]) > 1  # a Lie leg: one piece per step
    assert docs["constrained"]["constraints"]["legs"]
    assert {leg["strategy"] for leg in docs["constrained"]["legs"]} == {"constrained"}


@pytest.mark.parametrize("run", ["compare", "failed", "constrained"])
def test_the_files_of_run_records_validate(records, run):
    path = records[run]
    for name in ("result", "manifest"):
        assert errors(name, read(path / f"{name}.json")) == [], name
    manifest = read(path / "manifest.json")
    assert manifest["exit_code"] == (1 if run == "failed" else 0)
    if run == "constrained":  # every phase of the command's run
        assert list(manifest["phases"])[:5] == [
            "import",
            "check",
            "compile",
            "planning",
            "constraints",
        ]


def test_a_comparison_record_validates(records):
    doc = read(records["compare"] / "comparison.json")
    assert errors("comparison", doc) == []
    assert doc["screen"] is not None and doc["rows"][0]["status"] == "ok"
    assert {r["status"] for r in doc["rows"][1:]} == {"bounded"}
    assert "comparison files" in read(records["compare"] / "manifest.json")["phases"]


def test_a_sweep_directory_validates(sweep_dir):
    doc = read(sweep_dir / "sweep.json")
    assert errors("sweep", doc) == []
    # the key the other documents have (a CI script reads every record's `schema`), and the
    # one sweep.json had first, kept for its readers
    assert doc["schema"] == doc["format"] == "stratplan.sweep/1"
    assert doc["counts"]["ok"] == doc["counts"]["failed"] == 1
    assert doc["best"]["inputs"] == {"goal.q1": -0.5, "planner.max_iterations": 100}
    (record,) = (sweep_dir / "records").iterdir()  # the failed task's run record
    assert errors("result", read(record / "result.json")) == []
    assert errors("manifest", read(record / "manifest.json")) == []


@pytest.mark.slow
def test_a_urdf_record_validates(tmp_path):
    """A spatial plan: result.json's `attitude` section and the manifest's `urdf` entry."""
    plan = stratcli.plan(stratcli.load_scenario(SCENARIOS / "spatial" / "arm3_reorient.toml"))
    run = stratcli.write_record(tmp_path, plan, argv=["stratplan", "plan"])
    result, manifest = read(run / "result.json"), read(run / "manifest.json")
    assert errors("result", result) == [] and result["attitude"]["legs"]
    assert errors("manifest", manifest) == [] and manifest["urdf"]["file"] == "arm3.urdf"


# ------------------------------------------------------------------------------------------
# An undocumented key fails
# ------------------------------------------------------------------------------------------


def _add(doc: dict, where: tuple, key: str = "colour", value="blue") -> dict:
    """A copy of `doc` with `key` added to the object at path `where`."""
    changed = copy.deepcopy(doc)
    target = changed
    for step in where:
        target = target[step]
    target[key] = value
    return changed


@pytest.mark.parametrize(
    "where",
    [(), ("legs", 0), ("legs", 0, "pieces", 0), ("legs", 0, "pieces", 0, "basis"),
     ("switches", 0), ("optimisation",), ("optimisation", "starts", 0)],
)  # fmt: skip
def test_an_undocumented_key_in_result_json_fails(plans, where):
    doc = as_written(plans["energy"].to_dict())
    assert errors("result", doc) == []
    found = errors("result", _add(doc, where))
    at = "/".join(map(str, where)) + ":"
    assert any(e.startswith(at) and "'colour' was unexpected" in e for e in found), found


def test_an_undocumented_key_in_the_constraints_fails(plans):
    doc = as_written(plans["constrained"].to_dict())
    for where in (("constraints",), ("constraints", "legs", 0)):
        assert errors("result", _add(doc, where)), where


def test_an_undocumented_key_in_the_other_documents_fails(records, sweep_dir):
    manifest = read(records["compare"] / "manifest.json")
    comparison = read(records["compare"] / "comparison.json")
    sweep = read(sweep_dir / "sweep.json")
    cases = [
        ("manifest", manifest, ()),
        ("manifest", manifest, ("seeds",)),
        ("manifest", manifest, ("phases", "planning")),
        ("comparison", comparison, ()),
        ("comparison", comparison, ("rows", 0)),
        ("comparison", comparison, ("rows", 0, "legs", 0)),
        ("comparison", comparison, ("screen",)),
        ("comparison", comparison, ("settings",)),
        ("sweep", sweep, ()),
        ("sweep", sweep, ("executor",)),
        ("sweep", sweep, ("counts",)),
    ]
    for name, doc, where in cases:
        assert errors(name, doc) == []
        assert errors(name, _add(doc, where)), (name, where)
    # a phase the README does not name
    timed = {"wall_s": 0.1, "cpu_s": 0.1}
    assert errors("manifest", _add(manifest, ("phases",), "drawing", timed))
    assert errors("manifest", _add(manifest, ("phases",), "plots", timed)) == []
