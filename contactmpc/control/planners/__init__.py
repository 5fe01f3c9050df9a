"""Planners, one per file, behind the two-method interface of :class:`Planner`."""

from contactmpc.control.planners.base import PlanInfo, Planner
from contactmpc.control.planners.cem import CEM
from contactmpc.control.planners.mppi import MPPI
from contactmpc.control.planners.predictive_sampling import PredictiveSampling
from contactmpc.control.planners.replay import Replay

__all__ = ["CEM", "MPPI", "PlanInfo", "Planner", "PredictiveSampling", "Replay"]
