"""Use cases: what the command line and a notebook both call.

Every function returns an object and prints nothing. Bad input raises `InputError`; a
controllability check that fails before planning raises `NotControllableError`. A plan whose
legs did not all reach the goal is not an error: its outcome says so (`.ok`) and can still be
written as a run record.
"""

from .inspection import CheckReport as CheckReport
from .inspection import check_controllability as check_controllability
from .inspection import preset_models as preset_models
from .inspection import strata_table as strata_table
from .planning import ComparisonOutcome as ComparisonOutcome
from .planning import DecompositionOutcome as DecompositionOutcome
from .planning import PlanOutcome as PlanOutcome
from .planning import compare_sequences as compare_sequences
from .planning import decompose as decompose
from .planning import plan as plan
from .planning import plan_auto as plan_auto
from .planning import plan_run as plan_run
from .runs import RegressReport as RegressReport
from .runs import list_runs as list_runs
from .runs import load_run as load_run
from .runs import prepare_out as prepare_out
from .runs import read_run as read_run
from .runs import regress as regress
from .runs import write_record as write_record
