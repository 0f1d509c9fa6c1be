"""Leg planners: one interface (`base.LegPlanner`), one module per method.

The names below are the interface a planner of one's own uses (README "Your own leg
planner"): subclassing `LegPlanner` with a `method` registers it in `PLANNERS`.
"""

from .base import PLANNERS as PLANNERS
from .base import LegOutcome as LegOutcome
from .base import LegPlanner as LegPlanner
from .base import LegProblem as LegProblem
from .base import damped_gauss_newton as damped_gauss_newton
from .lie import LiePlanner as LiePlanner
from .newton import NewtonPlanner as NewtonPlanner
