"""Cross-entropy method over spline control points, one refit per replan."""

from __future__ import annotations

from typing import Annotated

import numpy as np

from contactmpc.control.planners.base import Planner
from contactmpc.validate import ConfigError, Ge, Gt, checked


class CEM(Planner):
    """Sample around the nominal with a per-control-point std; refit mean and std to the elites.

    The std lives on every control point (M, d), starts at the sampler's sigma and is refitted on
    the window at every replan, clamped to ``[min_std_ratio, max_std_ratio] x sigma``.

    Args:
        num_elites: number of lowest-cost samples the distribution is refitted to.
        min_std_ratio: lower bound of the std relative to the sampler's sigma.
        max_std_ratio: upper bound of the std relative to the sampler's sigma.
        **kwargs: see :class:`~contactmpc.control.planners.base.Planner`.
    """

    @checked
    def __init__(
        self,
        num_elites: Annotated[int, Ge(1)] = 8,
        min_std_ratio: Annotated[float, Ge(0)] = 0.1,
        max_std_ratio: Annotated[float, Gt(0)] = 1.0,
        **kwargs,
    ) -> None:
        super().__init__(**kwargs)
        if num_elites > self.num_samples:
            raise ConfigError(
                f"{type(self).__name__}.num_elites must be <= num_samples "
                f"({self.num_samples}), got {num_elites}"
            )
        self.num_elites = int(num_elites)
        self.min_std_ratio = float(min_std_ratio)
        self.max_std_ratio = float(max_std_ratio)
        self.std: np.ndarray | None = None

    def bind(self, *args, **kwargs) -> None:
        super().bind(*args, **kwargs)
        self.std = np.broadcast_to(self.noise_std, self.theta.shape).copy()

    def sample(self, rng: np.random.Generator, nominal: np.ndarray, window: np.ndarray) -> np.ndarray:
        return self.gaussian(rng, nominal, self.std[window])

    def update(self, candidates: np.ndarray, costs: np.ndarray, window: np.ndarray) -> np.ndarray:
        elites = candidates[np.argsort(costs, kind="stable")[: self.num_elites]]
        std = elites.std(axis=0)
        base = self.window_std(window)
        self.std[window] = np.clip(std, self.min_std_ratio * base, self.max_std_ratio * base)
        return elites.mean(axis=0)
