"""Batched open-loop rollouts of the planning model on a persistent ``mujoco.rollout`` thread pool."""

from __future__ import annotations

import os

import mujoco
import numpy as np
from mujoco import rollout


class RolloutEngine:
    """Rolls out batches of control sequences from one initial state.

    One ``MjData`` per thread and a persistent :class:`mujoco.rollout.Rollout` pool are created once;
    output buffers are reused between calls of the same batch shape.

    Args:
        model: the planning model (agent timestep).
        nthread: worker threads; ``None`` = the machine's cores.
    """

    def __init__(self, model: mujoco.MjModel, nthread: int | None = None) -> None:
        self.model = model
        self.nthread = int(nthread or os.cpu_count() or 1)
        self.datas = [mujoco.MjData(model) for _ in range(self.nthread)]
        self.pool = rollout.Rollout(nthread=self.nthread)
        self.nstate = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        self._buffers: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}

    def close(self) -> None:
        """Shut the thread pool down."""
        self.pool.close()

    def __enter__(self) -> RolloutEngine:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def run(
        self, initial_state: np.ndarray, controls: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Roll out ``controls`` from ``initial_state``.

        Args:
            initial_state: (nstate,) full-physics state (``mjSTATE_FULLPHYSICS``: time, qpos, qvel, ...).
            controls: (S, H, nu) controls; row h is applied during step h.

        Returns:
            state: (S, H, nstate) the state after each step.
            sensordata: (S, H, nsensordata); row h is measured before step h (row 0 = initial state).
            diverged: (S,) True where the simulation diverged (MuJoCo reset or non-finite values).
        """
        S, H, _ = controls.shape
        key = (S, H)
        if key not in self._buffers:
            self._buffers[key] = (
                np.empty((S, H, self.nstate)),
                np.empty((S, H, self.model.nsensordata)),
            )
        state, sensordata = self._buffers[key]
        x0 = np.broadcast_to(initial_state, (S, self.nstate))
        self.pool.rollout(
            self.model,
            self.datas,
            initial_state=np.ascontiguousarray(x0),
            control=np.ascontiguousarray(controls, dtype=np.float64),
            state=state,
            sensordata=sensordata,
        )
        # A diverged rollout stops advancing time (it repeats its last state); catch NaN/inf too.
        expected = initial_state[0] + H * self.model.opt.timestep
        diverged = np.abs(state[:, -1, 0] - expected) > 0.5 * self.model.opt.timestep
        diverged |= ~np.isfinite(sensordata).all(axis=(1, 2))
        return state, sensordata, diverged
