"""Batched open-loop rollouts of the planning model on a persistent ``mujoco.rollout`` thread pool."""

from __future__ import annotations

import math
import os

import mujoco
import numpy as np
from mujoco import rollout


def available_cpus() -> int:
    """CPUs this process may use: its affinity mask (what Slurm and ``taskset`` grant), capped by a
    cgroup CPU quota (containers, Slurm's cgroup plugin); ``os.cpu_count()`` counts the whole node.

    Returns:
        At least 1.
    """
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        cpus = os.cpu_count() or 1
    quota = _cgroup_cpu_quota()
    return max(1, min(cpus, quota) if quota else cpus)


def _cgroup_cpu_quota(root: str = "/sys/fs/cgroup") -> int | None:
    """The CPU quota of this process's cgroup, rounded up to whole CPUs; ``None`` without one.

    Reads cgroup v2 ``cpu.max`` (``"<quota> <period>"`` or ``"max <period>"``) or v1
    ``cpu/cpu.cfs_quota_us`` and ``cpu.cfs_period_us`` (quota -1: none).
    """
    v1 = f"{root}/cpu/cpu.cfs_"
    candidates = ((f"{root}/cpu.max", None), (f"{v1}quota_us", f"{v1}period_us"))
    for quota_file, period_file in candidates:
        try:
            with open(quota_file) as f:
                fields = f.read().split()
            if period_file is not None:
                with open(period_file) as f:
                    fields.append(f.read().strip())
        except OSError:
            continue
        if len(fields) < 2 or fields[0] in ("max", "-1"):
            return None
        quota, period = float(fields[0]), float(fields[1])
        return max(1, math.ceil(quota / period)) if quota > 0 and period > 0 else None
    return None


class RolloutEngine:
    """Rolls out batches of control sequences from one initial state.

    One ``MjData`` per thread and a persistent :class:`mujoco.rollout.Rollout` pool are created once;
    output buffers are reused between calls of the same batch shape.

    Args:
        model: the planning model (agent timestep).
        nthread: worker threads; ``None`` = the CPUs this process may use (:func:`available_cpus`).
        control_spec: the ``mjtState`` bits of a rollout's inputs per step: the controls (the default),
            or more (:mod:`~contactmpc.control.guidance`'s equality flags and mocap poses), which
            :meth:`run` appends to the controls.
        extra: (k,) the inputs besides the controls where :meth:`run` is given none (with
            ``control_spec`` beyond the controls).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        nthread: int | None = None,
        control_spec: int = int(mujoco.mjtState.mjSTATE_CTRL),
        extra: np.ndarray | None = None,
    ) -> None:
        self.model = model
        self.control_spec = int(control_spec)
        self.extra = None if extra is None else np.asarray(extra, dtype=float)
        self.nthread = int(nthread or available_cpus())
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
        self,
        initial_state: np.ndarray,
        controls: np.ndarray,
        models: list[mujoco.MjModel] | None = None,
        extra: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Roll out ``controls`` from ``initial_state``.

        Args:
            initial_state: (nstate,) full-physics state (``mjSTATE_FULLPHYSICS``: time, qpos, qvel, ...).
            controls: (S, H, nu) controls; row h is applied during step h.
            models: (S,) one model per rollout (variants of :attr:`model`, same sizes); ``None``: the
                engine's model for all.
            extra: (H, k) the inputs besides the controls per step, the same for every rollout (an engine
                whose ``control_spec`` has more than the controls); ``None``: the engine's ``extra``.

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
        if self.control_spec != mujoco.mjtState.mjSTATE_CTRL:
            more = self.extra if extra is None else extra
            more = np.broadcast_to(more, (S, H, more.shape[-1]))
            controls = np.concatenate([np.asarray(controls, dtype=np.float64), more], axis=-1)
        self.pool.rollout(
            self.model if models is None else models,
            self.datas,
            initial_state=np.ascontiguousarray(x0),
            control=np.ascontiguousarray(controls, dtype=np.float64),
            control_spec=self.control_spec,
            state=state,
            sensordata=sensordata,
        )
        # A diverged rollout stops advancing time (it repeats its last state); catch NaN/inf too.
        expected = initial_state[0] + H * self.model.opt.timestep
        diverged = np.abs(state[:, -1, 0] - expected) > 0.5 * self.model.opt.timestep
        diverged |= ~np.isfinite(sensordata).all(axis=(1, 2))
        return state, sensordata, diverged
