"""Use cases: what the command line and a notebook both call.

Every function returns an object and prints nothing. Bad input raises `InputError`; a
controllability check that fails before planning raises `NotControllableError`. A plan whose
legs did not all reach the goal is not an error: its outcome says so (`.ok`) and can still be
written as a run record.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

# Where each name lives; imported on first use (PEP 562), for start-up speed: `stratplan runs`
# and `show` reach `api.list_runs` / `api.read_run` without importing the planner (scipy,
# sympy, matplotlib), as `stratcli/__init__.py` does for the top-level names.
_NAMES = {
    "CheckReport": "inspection",
    "check_controllability": "inspection",
    "limit_warnings": "inspection",
    "preset_models": "inspection",
    "strata_table": "inspection",
    "urdf_facts": "inspection",
    "ComparisonOutcome": "outcomes",
    "DecompositionOutcome": "outcomes",
    "PlanOutcome": "outcomes",
    "compare_sequences": "sequences",
    "decompose": "sequences",
    "plan": "planning",
    "plan_auto": "planning",
    "plan_run": "planning",
    "RegressReport": "regression",
    "SweepReport": "sweeps",
    "read_sweep": "sweeps",
    "run_sweep": "sweeps",
    "list_runs": "runs",
    "load_run": "runs",
    "draw_ahead": "runs",
    "prepare_out": "runs",
    "read_run": "runs",
    "regress": "regression",
    "write_record": "runs",
}

__all__ = list(_NAMES)


def __getattr__(name: str) -> Any:
    module = _NAMES.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f".{module}", __name__), name)
    globals()[name] = value  # once imported, a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


if TYPE_CHECKING:  # the same names, for type checkers and IDEs
    from .inspection import CheckReport as CheckReport
    from .inspection import check_controllability as check_controllability
    from .inspection import limit_warnings as limit_warnings
    from .inspection import preset_models as preset_models
    from .inspection import strata_table as strata_table
    from .inspection import urdf_facts as urdf_facts
    from .outcomes import ComparisonOutcome as ComparisonOutcome
    from .outcomes import DecompositionOutcome as DecompositionOutcome
    from .outcomes import PlanOutcome as PlanOutcome
    from .planning import plan as plan
    from .planning import plan_auto as plan_auto
    from .planning import plan_run as plan_run
    from .regression import RegressReport as RegressReport
    from .regression import regress as regress
    from .runs import draw_ahead as draw_ahead
    from .runs import list_runs as list_runs
    from .runs import load_run as load_run
    from .runs import prepare_out as prepare_out
    from .runs import read_run as read_run
    from .runs import write_record as write_record
    from .sequences import compare_sequences as compare_sequences
    from .sequences import decompose as decompose
    from .sweeps import SweepReport as SweepReport
    from .sweeps import read_sweep as read_sweep
    from .sweeps import run_sweep as run_sweep
