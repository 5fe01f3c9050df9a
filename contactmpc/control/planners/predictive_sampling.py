"""Max-selection predictive sampling (paper §II-C)."""

from __future__ import annotations

import numpy as np

from contactmpc.control.planners.base import Planner


class PredictiveSampling(Planner):
    """Perturb the window's control points with Gaussian noise; the cheapest rollout wins.

    Sample 0 is the unperturbed nominal, so the committed control points never score worse than
    the incumbent on the planning model.
    """

    def sample(self, rng: np.random.Generator, nominal: np.ndarray, window: np.ndarray) -> np.ndarray:
        return self.gaussian(rng, nominal, self.window_std(window))

    def update(self, candidates: np.ndarray, costs: np.ndarray, window: np.ndarray) -> np.ndarray:
        return candidates[int(np.argmin(costs))]
