"""Robust planning: score each candidate under an ensemble of randomised planning models.

With ``planner.robust`` set to a :class:`ModelEnsemble`, every candidate of a planning iteration is
rolled out under ``K`` copies of the planning model whose object mass and friction are drawn from the
ensemble's widths (``mujoco.rollout`` takes one model per rollout), and its cost is the ensemble's risk
measure over the ``K`` rollouts: the mean, the worst, or the CVaR (the mean of the worst ``alpha``
share), as hydrax offers. ``K = 1`` with zero widths is plain planning, bit for bit.

The ensemble is drawn once, when the planner is bound to a problem, from the ensemble's own ``seed``.
"""

from __future__ import annotations

import copy
import math
from typing import TYPE_CHECKING, Annotated

import mujoco
import numpy as np

from contactmpc.validate import Ge, Gt, Le, OneOf, checked

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["ModelEnsemble"]


class ModelEnsemble:
    """``K`` randomised planning models and a risk measure over them.

    Args:
        num_models: ``K``, rollouts per candidate.
        mass_scale: half-width of the factor on the object's masses and inertias, drawn per model in
            ``[1 - w, 1 + w]``.
        friction_scale: half-width of the factor on the object geoms' sliding friction.
        risk: ``mean``, ``worst`` (the largest cost) or ``cvar`` (the mean of the ``cvar_alpha`` share
            of largest costs, at least one).
        cvar_alpha: the share of worst models the CVaR averages.
        seed: seed of the models' draw.
    """

    @checked
    def __init__(
        self,
        num_models: Annotated[int, Ge(1)] = 4,
        mass_scale: Annotated[float, Ge(0), Le(0.99)] = 0.0,
        friction_scale: Annotated[float, Ge(0), Le(0.99)] = 0.0,
        risk: Annotated[str, OneOf("mean", "worst", "cvar")] = "mean",
        cvar_alpha: Annotated[float, Gt(0), Le(1)] = 0.25,
        seed: Annotated[int, Ge(0)] = 0,
    ) -> None:
        self.num_models = int(num_models)
        self.mass_scale = float(mass_scale)
        self.friction_scale = float(friction_scale)
        self.risk = risk
        self.cvar_alpha = float(cvar_alpha)
        self.seed = int(seed)
        self.scales: np.ndarray | None = None

    def build(self, scene: Scene) -> list[mujoco.MjModel]:
        """The ``K`` planning models: ``scene.planner_model`` itself where a model draws no change.

        Also sets :attr:`scales`, (K, 2) each model's mass and friction factors.
        """
        rng = np.random.default_rng(self.seed)
        base = scene.planner_model
        bodies = np.flatnonzero(scene.index.object_body_mask)
        geoms = np.flatnonzero(np.isin(base.geom_bodyid, bodies))
        models, scales = [], []
        for _ in range(self.num_models):
            mass = float(rng.uniform(1 - self.mass_scale, 1 + self.mass_scale)) if self.mass_scale else 1.0
            friction = (
                float(rng.uniform(1 - self.friction_scale, 1 + self.friction_scale))
                if self.friction_scale
                else 1.0
            )
            scales.append((mass, friction))
            if (mass, friction) == (1.0, 1.0):
                models.append(base)
                continue
            m = copy.copy(base)
            m.body_mass[bodies] *= mass
            m.body_inertia[bodies] *= mass
            m.geom_friction[geoms, 0] *= friction
            models.append(m)
        self.scales = np.asarray(scales)
        return models

    def aggregate(self, costs: np.ndarray) -> np.ndarray:
        """(S,) the risk over the models of costs (K, S) (``inf`` stays ``inf``)."""
        if self.risk == "mean":
            return costs.mean(axis=0)
        if self.risk == "worst":
            return costs.max(axis=0)
        k = max(1, math.ceil(self.cvar_alpha * costs.shape[0]))
        return np.sort(costs, axis=0)[-k:].mean(axis=0)
