"""Planning latency modelled from the planner's size: MuJoCo MPC's loop, made deterministic.

In the authors' MuJoCo MPC the physics runs in real time in one thread while the planner replans in a
loop as fast as its threads allow (``Agent::Plan``): a plan is applied one planning iteration's compute
time *L* after the state it was planned from, and the next plan starts from the state at that moment.
:class:`ComputeLatency` prices *L* from the configuration alone (never from a clock), so that the same
config and seed give the same record on any machine:

    L = ceil(rollouts x horizon steps x sample_step_seconds / threads / plant step) x plant step

with ``rollouts`` the planner's samples (times the models of a robust ensemble). The trial loop
(:class:`~contactmpc.trial.Trial`) applies it: :meth:`~contactmpc.control.planners.base.Planner.latency_for`.
"""

from __future__ import annotations

import math
from typing import Annotated

from contactmpc.validate import Ge, Gt, checked


class ComputeLatency:
    """The compute time of one planning iteration, from a stated cost per simulated step.

    Args:
        sample_step_seconds: CPU seconds one rollout step of the planning model costs (with the
            planner's overhead), e.g. the benchmark's (``python launch.py job=benchmark``) per-step cost.
        threads: rollout threads the modelled machine plans with (the paper: 7 of an M1's 10).
    """

    @checked
    def __init__(
        self,
        sample_step_seconds: Annotated[float, Gt(0)] = 16e-6,
        threads: Annotated[int, Ge(1)] = 7,
    ) -> None:
        self.sample_step_seconds = float(sample_step_seconds)
        self.threads = int(threads)

    def seconds(self, rollouts: int, steps: int, plant_timestep: float) -> float:
        """The latency (s): the iteration's compute time rounded up to a whole number of plant steps.

        Args:
            rollouts: rollouts of one iteration (samples x models).
            steps: planning-model steps per rollout (horizon / planning step).
            plant_timestep: the plant's step (s).
        """
        compute = rollouts * steps * self.sample_step_seconds / self.threads
        # 1e-9: a compute time on the grid up to rounding stays on it
        return math.ceil(compute / plant_timestep - 1e-9) * plant_timestep
