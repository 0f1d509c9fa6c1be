"""JSON Schemas (draft 2020-12) of the JSON documents a run or a sweep writes (stdlib only).

`result.json` (`stratplan.result/1`), `manifest.json` (`stratplan.manifest/1`),
`comparison.json` (`stratplan.comparison/1`) and a sweep directory's `sweep.json`
(`stratplan.sweep/1`): each schema is the file `<name>.schema.json` beside this module,
shipped with the package, whose `$id` and `title` are the document's own `schema` (`format`
for sweep.json) string. Each is closed (`additionalProperties: false`) wherever the document
is, so a key the schema does not describe fails validation; the open parts are a
`[constraints]` table's `spec` (the scenario schema's keys), a sweep's `best.inputs` (its
keys) and the objects keyed by names (inputs, sequences, phases). The MCAP channels' schemas
are in `mcap_schemas`.
"""

from __future__ import annotations

import json
from importlib.resources import files
from typing import Any

from ...arguments import checked, choice

__all__ = ["NAMES", "record_schema"]

NAMES = ("result", "manifest", "comparison", "sweep")


@checked(name=choice(*NAMES))
def record_schema(name: str) -> dict[str, Any]:
    """The JSON Schema of one of the documents stratplan writes.

    Parameters
    ----------
    name : str
        "result" (result.json), "manifest" (manifest.json), "comparison" (comparison.json)
        or "sweep" (sweep.json).

    Returns
    -------
    dict
        The schema (a new dict each call), e.g. for ``jsonschema.validate(doc, schema)``.

    Raises
    ------
    InputError
        `name` is not one of those.
    TypeError
        `name` is not a string.
    """
    text = files(__name__).joinpath(f"{name}.schema.json").read_text(encoding="utf-8")
    return json.loads(text)
