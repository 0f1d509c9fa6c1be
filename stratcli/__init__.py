"""stratplan: motion planning for stratified nonholonomic systems (Duleba & Opalka).

The public API, in full (everything else is internal)::

    import stratcli

    task = stratcli.load_scenario({...})    # a path, TOML text or a dict
    plan = stratcli.plan(task)              # -> SequencePlan (frozen, picklable)
    t, q, u = plan.sample()                 # re-integrated, on the real time axis
    run = stratcli.write_record("runs", plan)
    again = stratcli.load_run(run)          # -> SequencePlan, nothing re-planned

Use cases: `load_scenario`, `plan`, `plan_auto`, `decompose`, `compare_sequences`,
`check_controllability`, `load_run`, `write_record`, `time_scaled`, `run_sweep`,
`read_sweep`, `record_schema` (the JSON Schema of result.json, manifest.json,
comparison.json or sweep.json). Values: `SequencePlan`,
`LegPlan`, `Piece`, `Switch`, `Optimisation`, `StartOutcome`, `ModelRef`, `Timings`,
`Trajectory`, `Task`, `LegSpec`, and the settings `PlannerSettings`, `LieSettings`,
`DecomposeSettings`, `FourierBasis`. Models: `System`, `Stratum`, `PlanarManipulator`, `Arm`,
`Base`, `Link`, `preset`. Outcomes: `Status`; `PlanOutcome` (a plan in `.result` with its
result.json and timings) and `ComparisonOutcome` (what `plan_auto` and `compare_sequences`
return: the ranking, and in `.best` the chosen sequence's `PlanOutcome`, its plan in
`.best.result`), `DecompositionOutcome` (`decompose`), `CheckReport`
(`check_controllability`), `SweepOutcome` (`run_sweep`), `SweepReport` (`read_sweep`).
Errors: `StratplanError`, `InputError`, `ModelError`, `NotControllableError`, `RecordError`
(`write_record` could not write), `Problem`; warnings: `IllConditionedWarning`, `LimitWarning`,
`UnusedLegsWarning`.

Arguments are checked before any work: a value of the wrong type raises `TypeError`, a value
out of range or not one of the choices `InputError` (a `ValueError`); both name the argument.

Extension point: a leg planner of your own is a subclass of `stratcli.planners.LegPlanner`
(README "Your own leg planner"). A model of your own is a `[model]` table (a dict).
"""

from __future__ import annotations

import time
from importlib import import_module
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"
_STARTED = time.perf_counter()  # the wall clock's zero of a run's phases (manifest "phases")

# Where each public name lives. Names are imported on first use (PEP 562): `import stratcli`
# is what the `stratplan` command does first, and `stratplan --help` must not pay for scipy,
# sympy and matplotlib (start-up speed is the only reason; the table below is the complete,
# explicit list of dependencies, mirrored for type checkers under TYPE_CHECKING).
_PUBLIC = {
    "load_scenario": "scenario",
    "Task": "task",
    "plan": "api",
    "plan_auto": "api",
    "decompose": "api",
    "compare_sequences": "api",
    "check_controllability": "api",
    "load_run": "api",
    "write_record": "api",
    "run_sweep": "api",
    "read_sweep": "api",
    "record_schema": "records.schemas",
    "time_scaled": "time_scaling",
    "PlanOutcome": "api",
    "ComparisonOutcome": "api",
    "DecompositionOutcome": "api",
    "CheckReport": "api",
    "SweepReport": "api",
    "SweepOutcome": "sweep.run",
    "LegSpec": "stratified",
    "SequencePlan": "sequence",
    "LegPlan": "results",
    "Piece": "results",
    "Switch": "results",
    "Optimisation": "results",
    "StartOutcome": "results",
    "ModelRef": "results",
    "Timings": "results",
    "Trajectory": "simulate",
    "PlannerSettings": "settings",
    "LieSettings": "settings",
    "DecomposeSettings": "settings",
    "FourierBasis": "controls",
    "System": "models.system",
    "Stratum": "models.system",
    "PlanarManipulator": "models.planar",
    "Arm": "models.planar",
    "Base": "models.planar",
    "Link": "models.planar",
    "preset": "models.presets",
    "Status": "status",
    "StratplanError": "errors",
    "InputError": "errors",
    "ModelError": "errors",
    "NotControllableError": "errors",
    "IllConditionedWarning": "errors",
    "LimitWarning": "errors",
    "UnusedLegsWarning": "errors",
    "RecordError": "errors",
    "Problem": "errors",
}

__all__ = ["__version__", *_PUBLIC]


def __getattr__(name: str) -> Any:
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'stratcli' has no attribute {name!r}")
    value = getattr(import_module(f".{module}", __name__), name)
    globals()[name] = value  # once imported, a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


if TYPE_CHECKING:  # the same names, for type checkers and IDEs
    from .api import CheckReport as CheckReport
    from .api import ComparisonOutcome as ComparisonOutcome
    from .api import DecompositionOutcome as DecompositionOutcome
    from .api import PlanOutcome as PlanOutcome
    from .api import SweepReport as SweepReport
    from .api import check_controllability as check_controllability
    from .api import compare_sequences as compare_sequences
    from .api import decompose as decompose
    from .api import load_run as load_run
    from .api import plan as plan
    from .api import plan_auto as plan_auto
    from .api import read_sweep as read_sweep
    from .api import run_sweep as run_sweep
    from .api import write_record as write_record
    from .controls import FourierBasis as FourierBasis
    from .errors import IllConditionedWarning as IllConditionedWarning
    from .errors import InputError as InputError
    from .errors import LimitWarning as LimitWarning
    from .errors import ModelError as ModelError
    from .errors import NotControllableError as NotControllableError
    from .errors import Problem as Problem
    from .errors import RecordError as RecordError
    from .errors import StratplanError as StratplanError
    from .errors import UnusedLegsWarning as UnusedLegsWarning
    from .models.planar import Arm as Arm
    from .models.planar import Base as Base
    from .models.planar import Link as Link
    from .models.planar import PlanarManipulator as PlanarManipulator
    from .models.presets import preset as preset
    from .models.system import Stratum as Stratum
    from .models.system import System as System
    from .records.schemas import record_schema as record_schema
    from .results import LegPlan as LegPlan
    from .results import ModelRef as ModelRef
    from .results import Optimisation as Optimisation
    from .results import Piece as Piece
    from .results import StartOutcome as StartOutcome
    from .results import Switch as Switch
    from .results import Timings as Timings
    from .scenario import load_scenario as load_scenario
    from .sequence import SequencePlan as SequencePlan
    from .settings import DecomposeSettings as DecomposeSettings
    from .settings import LieSettings as LieSettings
    from .settings import PlannerSettings as PlannerSettings
    from .simulate import Trajectory as Trajectory
    from .status import Status as Status
    from .stratified import LegSpec as LegSpec
    from .sweep.run import SweepOutcome as SweepOutcome
    from .task import Task as Task
    from .time_scaling import time_scaled as time_scaled
