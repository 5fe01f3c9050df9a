"""No planning: track the reference open-loop (the baseline that shows what MPC adds)."""

from __future__ import annotations

import numpy as np

from contactmpc.control.planners.base import Planner


class Replay(Planner):
    """Commit the reference's own control points and never change them."""

    needs_rollouts = False

    def sample(self, rng: np.random.Generator, nominal: np.ndarray, window: np.ndarray) -> np.ndarray:
        return nominal[None]

    def update(self, candidates: np.ndarray, costs: np.ndarray, window: np.ndarray) -> np.ndarray:
        return candidates[0]
