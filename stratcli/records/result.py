"""The `result.json` document of a plan (schema "stratplan.result/1").

The document is the plan value's own serialisation (`SequencePlan.to_dict`, built in
`stratcli.resultdoc`); this module only fills in what the scenario knows.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from ..results import SCHEMA
from ..sequence import SequencePlan

__all__ = ["SCHEMA", "result_document"]


def result_document(
    plan: SequencePlan, scenario: str, model: str, reference_energy: float | None = None
) -> dict[str, Any]:
    """The JSON-ready result of a planned (or failed) sequence, named after its scenario."""
    named = replace(plan, scenario=scenario, reference_energy=reference_energy)
    doc = named.to_dict()
    doc["model"] = model
    return doc
