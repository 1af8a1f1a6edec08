"""Station planning: several robots' welds assigned, ordered, planned, coordinated and run with their cables."""

from .config import EXTRA_ROUNDS, LEG_PLANNERS, RECORD_EVERY, StationPlanConfig
from .jams import REROUTES, jammed_legs
from .legs import LegBook, LegRun
from .legs_up_front import move_key
from .plan import StationPlan, save_plan
from .planner import StationPlanner
from .problem import BLOCKED, CONFLICT_DISTANCE, CONFLICT_WAIT

__all__ = ["BLOCKED", "CONFLICT_DISTANCE", "CONFLICT_WAIT", "EXTRA_ROUNDS", "LEG_PLANNERS", "RECORD_EVERY", "REROUTES",
           "LegBook", "LegRun", "StationPlan", "StationPlanConfig", "StationPlanner", "jammed_legs", "move_key",
           "save_plan"]
