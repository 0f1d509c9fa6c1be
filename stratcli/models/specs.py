"""Rebuilding a model from the reference a plan keeps (`results.ModelRef`).

A plan refers to its model by name and, when it came from a scenario, by the scenario's
`[model]` table. Building a model compiles sympy expressions (0.3–0.5 s for a preset), so
models are cached by their reference: a plan loaded from a record, or unpickled in another
process, finds the model already built.
"""

from __future__ import annotations

from functools import lru_cache

from .presets import PRESETS, preset
from .system import System

__all__ = ["system_from_ref"]


@lru_cache(maxsize=16)
def _from_json(kind: str, text: str) -> System:
    from ..scenario import Scenario, build_system  # TODO(layers): move specs into models

    spec = Scenario.model_fields["model"].annotation  # the discriminated union of [model]
    from pydantic import TypeAdapter

    return build_system(TypeAdapter(spec).validate_json(text))


def system_from_ref(ref) -> System:
    """The model a `ModelRef` names, built once per process.

    Raises
    ------
    ValueError
        When the plan's model was made in Python (no `[model]` table to rebuild it from):
        bind it with `plan.with_system(system)`.
    """
    spec = ref.spec
    if spec is not None:
        return _from_json(spec.kind, spec.model_dump_json())
    if ref.name in PRESETS:
        return preset(ref.name)
    raise ValueError(
        f"the plan's model {ref.name!r} was made in Python and cannot be rebuilt; "
        "use plan.with_system(system)"
    )
