"""Model-predictive path integral control over spline control points."""

from __future__ import annotations

from typing import Annotated

import numpy as np

from contactmpc.control.planners.base import Planner
from contactmpc.validate import Gt, checked


class MPPI(Planner):
    """Exponentially cost-weighted average of Gaussian samples.

    The weights are ``softmax(-(c - min c) / (temperature * (median c - min c)))``: the temperature is
    relative to the spread of the costs, so one value works across tasks and cost scales.

    Args:
        temperature: relative temperature (> 0); small values approach predictive sampling.
        **kwargs: see :class:`~contactmpc.control.planners.base.Planner`.
    """

    @checked
    def __init__(self, temperature: Annotated[float, Gt(0)] = 0.1, **kwargs) -> None:
        super().__init__(**kwargs)
        self.temperature = float(temperature)

    def sample(self, rng: np.random.Generator, nominal: np.ndarray, window: np.ndarray) -> np.ndarray:
        return self.gaussian(rng, nominal, self.window_std(window))

    def update(self, candidates: np.ndarray, costs: np.ndarray, window: np.ndarray) -> np.ndarray:
        finite = np.isfinite(costs)
        if not finite.any():
            return candidates[0]
        c = np.where(finite, costs, np.inf)
        lo = c.min()
        scale = max(float(np.median(c[finite]) - lo), 1e-12) * self.temperature
        w = np.exp(-(c - lo) / scale)
        w /= w.sum()
        return np.tensordot(w, candidates, axes=1)
