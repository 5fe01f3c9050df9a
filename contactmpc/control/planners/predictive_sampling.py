"""Max-selection predictive sampling (paper §II-C), or an elite-weighted update rolled out and checked."""

from __future__ import annotations

from typing import Annotated

import numpy as np

from contactmpc.control.planners.base import Planner, Scored
from contactmpc.validate import Gt, OneOf, checked


class PredictiveSampling(Planner):
    """Perturb the window's control points with Gaussian noise; the cheapest rollout wins.

    Sample 0 is the unperturbed nominal, so the committed control points never score worse than
    the incumbent on the planning model.

    With ``update="elite_softmax"`` (SPIDER's update) the candidate committed is instead the softmax-weighted
    mean of the elites, the ``elite_fraction`` cheapest samples: weights ``exp(-(c - c_min) / (temperature
    x (c_max - c_min)))`` over the elites' costs ``c`` (the temperature relative to their spread, as
    :class:`~contactmpc.control.planners.MPPI`'s). The mean is rolled out (one rollout more per iteration,
    which the latency model charges) and committed only where it costs no more than the cheapest sample;
    else the cheapest sample is, as with max-selection. So the committed cost is never above max-selection's
    on the same candidates.

    Args:
        update: ``max`` (the paper) or ``elite_softmax``.
        elite_fraction: the fraction of the samples that are elites (at least 2 of them; SPIDER: 0.1).
        temperature: the softmax's temperature relative to the elites' cost spread (> 0).
        **kwargs: see :class:`~contactmpc.control.planners.base.Planner`.
    """

    @checked
    def __init__(
        self,
        update: Annotated[str, OneOf("max", "elite_softmax")] = "max",
        elite_fraction: Annotated[float, Gt(0)] = 0.1,
        temperature: Annotated[float, Gt(0)] = 1.0,
        **kwargs,
    ) -> None:
        super().__init__(**kwargs)
        self.update_rule = update  # not ``self.update``: that is the method
        self.elite_fraction = min(float(elite_fraction), 1.0)
        self.temperature = float(temperature)
        self.extra_rollouts = 1 if update == "elite_softmax" else 0

    def sample(self, rng: np.random.Generator, nominal: np.ndarray, window: np.ndarray) -> np.ndarray:
        return self.gaussian(rng, nominal, self.window_std(window))

    def update(self, candidates: np.ndarray, costs: np.ndarray, window: np.ndarray) -> np.ndarray:
        return candidates[int(np.argmin(costs))]

    def elite_mean(self, candidates: np.ndarray, costs: np.ndarray) -> np.ndarray | None:
        """(Mw, d) the softmax-weighted mean of the elites among ``candidates`` (S, Mw, d) scored
        ``costs`` (S,); ``None`` where fewer than two elites have a finite cost."""
        count = max(2, int(np.ceil(self.elite_fraction * len(costs))))
        elites = np.argsort(costs, kind="stable")[:count]
        elites = elites[np.isfinite(costs[elites])]
        if len(elites) < 2:
            return None
        c = costs[elites]
        spread = max(float(c[-1] - c[0]), 1e-12)
        w = np.exp(-(c - c[0]) / (self.temperature * spread))
        return np.tensordot(w / w.sum(), candidates[elites], axes=1)

    def commit(self, scored: Scored) -> tuple[np.ndarray, float, dict[str, float]]:
        chosen = super().commit(scored)
        if self.update_rule == "max":
            return chosen
        mean = self.elite_mean(scored.candidates, scored.total)
        if mean is None:
            return chosen
        theta = self.theta.copy()
        theta[scored.window] = mean
        cost, mean_terms, _ = self.evaluate(scored.state, scored.t, theta[None])
        if not cost[0] <= chosen[1]:  # the cheapest sample stays (also where the mean diverged)
            return chosen
        return mean, float(cost[0]), {k: float(v[0]) for k, v in mean_terms.items()}
